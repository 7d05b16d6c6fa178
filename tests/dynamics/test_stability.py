"""An explicit step beyond the stability limit is refused, and the limit is the real one."""

import numpy as np
import pytest

from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.engine import NonFiniteStateError
from postcapture.dynamics.integrators import TABLEAUX
from postcapture.dynamics.process_model import NativeProcessModel
from postcapture.dynamics.simulate import simulate_system
from postcapture.dynamics.stability import StepTooLargeError, _polynomial, _ray_limits, stability_limit


def test_rk4_stability_interval_closed_forms():
    """RK4's stability region meets the negative real axis at 2.7853 and the imaginary axis at 2 sqrt(2)."""
    coef = _polynomial(TABLEAUX["rk4"])
    np.testing.assert_allclose(coef, [1, 1, 1 / 2, 1 / 6, 1 / 24], rtol=1e-15)
    limits = _ray_limits(coef, np.array([-1.0 + 0j, 1j]))
    np.testing.assert_allclose(limits, [2.785293563405282, 2 * np.sqrt(2)], rtol=1e-9)


@pytest.mark.parametrize("segments,limit_ms", [(5, 2.19), (20, 0.18)])
def test_the_limit_of_rk4_on_the_plant(envisat, segments, limit_ms):
    system = build_system(envisat, panel_segments=segments)
    q, v = initial_state(system)
    limit, lam = stability_limit(CompiledPlant(system, "rk4"), q, v)
    assert limit == pytest.approx(limit_ms * 1e-3, rel=0.03)
    assert lam.real < 0  # a damper's eigenvalue at -beta omega^2 sets it


def test_a_step_beyond_the_limit_is_refused_and_would_blow_up(envisat):
    system = build_system(envisat, panel_segments=5)
    q, v = initial_state(system)
    plant = CompiledPlant(system, "rk4")
    limit, _ = stability_limit(plant, q, v)
    with pytest.raises(StepTooLargeError, match=r"beyond rk4's stability limit .* use a step <= ") as info:
        simulate_system(system, q, v, 1.0, step=1.3 * limit, sample_period=1.3 * limit, integrator="rk4")
    assert info.value.limit == pytest.approx(limit) and isinstance(info.value, ValueError)
    with pytest.raises(StepTooLargeError):
        NativeProcessModel(system, 1.3 * limit, "rk4")

    def largest_joint(h):  # the core itself does not refuse: what the refusal prevents
        try:
            run = plant.simulate(q, v, 0.0, h, 100, 40)
        except NonFiniteStateError:
            return np.inf
        return np.abs(run["q"][:, 7:]).max()

    assert largest_joint(0.9 * limit) < 0.1
    assert largest_joint(1.3 * limit) > 1.0
    traj = simulate_system(system, q, v, 2.0, step=0.95 * limit, sample_period=100 * 0.95 * limit, integrator="rk4")
    assert np.isfinite(traj.q).all()


def test_implicit_methods_are_not_limited(envisat):
    system = build_system(envisat, panel_segments=20)
    q, v = initial_state(system)
    assert stability_limit(CompiledPlant(system, "sdirk4"), q, v)[0] == np.inf
