"""Pure numerics on float64 SI arrays: rotations, Kalman kernels, the sigmoid map, chi-square bounds.

Nothing in this package imports Pinocchio, FMPy or any other layer of postcapture.
"""
