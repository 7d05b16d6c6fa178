"""Multibody plant: the Pinocchio model and springs (System), the compiled core that computes the plant's
equations, integrators and exact derivatives (core, csrc/), truth simulation."""
