"""FMI: export of the plant as a co-simulation FMU, and FMU-backed process models (FMPy)."""
