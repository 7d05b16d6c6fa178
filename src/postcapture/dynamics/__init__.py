"""Multibody plant: the tree as plain data and the immutable description (System), the compiled core that
computes the plant's equations, integrators and exact derivatives (core, engine, csrc/), truth simulation."""
