"""Multibody plant: Pinocchio model, springs, integrators, exact derivatives, truth simulation."""
