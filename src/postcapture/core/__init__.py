"""Pure numerics on float64 SI arrays: rotations, Kalman kernels, the sigmoid map, chi-square bounds.

Modules: ``rotations`` (every quaternion convention), ``kalman`` (predict / Joseph update / gating),
``sigmoid`` (constrained-parameter map), ``consistency`` (NEES, NIS, bounds), ``farrenkopf``
(analytic attitude-filter accuracy), ``timegrid`` (sample instants), ``units`` (datasheet units to SI),
``errors`` (typed exceptions).

Nothing in this package imports Pinocchio, FMPy or any other layer of postcapture.
"""
