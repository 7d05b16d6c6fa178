"""Helpers shared by the FMI tests."""

import numpy as np

__all__ = ["native_model", "native_trajectory", "rel", "state_names"]


def native_model(system, step, integrator="sdirk3"):
    """The native process model with its default settings: it runs the same compiled core as the FMU."""
    from postcapture.dynamics.process_model import NativeProcessModel

    return NativeProcessModel(system, step, integrator)


def rel(a, b) -> float:
    """Largest entry difference relative to the largest entry of the reference."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / np.abs(b).max())


def state_names(system) -> list[str]:
    """The exported FMU's state variables ``q[1]``..., ``v[1]``..., in the state's order."""
    return [f"q[{i + 1}]" for i in range(system.nq)] + [f"v[{i + 1}]" for i in range(system.nv)]


def native_trajectory(system, report, t_end: float, dt: float):
    """The native process model's states on the grid ``k dt`` up to ``t_end``, shape (nx, n + 1), taking each
    ``dt`` in the internal steps the FMU of ``report`` takes (its integrator; ``dt`` whole multiples of its
    step, else the fewest equal steps no longer than it)."""
    steps = int(round(dt / report.step))
    h = report.step if steps >= 1 and abs(steps * report.step - dt) <= 1e-9 * dt else dt / np.ceil(dt / report.step)
    model = native_model(system, h, report.integrator)
    x = model.initial_state()
    n = int(round(t_end / dt))
    X = np.zeros((x.size, n + 1))
    X[:, 0] = x
    for k in range(n):
        x = model.predict(x, k * dt, dt).x
        X[:, k + 1] = x
    return X
