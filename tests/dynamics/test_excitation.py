"""The excitation profiles (one implementation: the compiled core's ``pc_inputs_eval``, read through
``InputSchedule``) against closed forms written here, the ``[start, stop)`` window and the left limit at
a switch, and the model's own input assembly (``pc_inputs``) against the same schedule."""

import math

import numpy as np
import pytest

from postcapture.config.excitation import Chirp, Sine, Step, Table
from postcapture.dynamics.build import build_system
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.excitation import InputSchedule

FX, TZ, J2 = 0, 5, 7  # force_x, torque_z, joint_2 with n_arm = 2


def _u(profiles, t, left=False, n_arm=2):
    """One channel's values per time, through ``InputSchedule.sample``; also checks ``__call__``."""
    schedule = InputSchedule(profiles, n_arm)
    t = np.asarray(t, dtype=float)
    u = schedule.sample(t, left=left)
    assert u.shape == (6 + n_arm, t.size)
    for k, tk in enumerate(t):
        np.testing.assert_array_equal(schedule(tk, left=left), u[:, k])
    return u


def test_step_without_rise_is_a_window():
    p = Step(kind="step", channel="force_x", amplitude=3.5, start=2.0, stop=5.0)
    t = [0.0, 1.999, 2.0, 3.0, 4.999, 5.0, 9.0]
    u = _u([p], t)
    np.testing.assert_array_equal(u[FX], [0.0, 0.0, 3.5, 3.5, 3.5, 0.0, 0.0])
    assert not np.any(np.delete(u, FX, axis=0))
    # left limits: off at the start, still on at the stop
    np.testing.assert_array_equal(_u([p], [2.0, 5.0], left=True)[FX], [0.0, 3.5])


def test_step_with_rise_is_a_trapezoid():
    a, t0, t1, r = -4.0, 1.0, 3.0, 0.5
    p = Step(kind="step", channel="torque_z", amplitude=a, start=t0, stop=t1, rise_time=r)
    t = np.array([t0, t0 + 0.1, t0 + r / 2, t0 + r, 2.0, t1 - r, t1 - 0.2, t1 - 1e-9])

    def closed(tt):  # linear ramps of length r after start and before stop
        return a * min(1.0, (tt - t0) / r, (t1 - tt) / r)

    np.testing.assert_allclose(_u([p], t)[TZ], [closed(x) for x in t], rtol=1e-12, atol=1e-12)
    # a step without a stop ramps up and stays
    q = Step(kind="step", channel="torque_z", amplitude=a, start=t0, rise_time=r)
    np.testing.assert_allclose(_u([q], [t0 + 0.2, t0 + r, 1e6])[TZ], [a * 0.2 / r, a, a], rtol=1e-12)
    # a window shorter than two rise times is a triangle peaking at its middle
    tri = Step(kind="step", channel="torque_z", amplitude=a, start=0.0, stop=0.6, rise_time=0.5)
    np.testing.assert_allclose(_u([tri], [0.3])[TZ], [a * 0.3 / 0.5], rtol=1e-12)


def test_sine_with_offset_and_phase():
    A, f, ph, off, t0, t1 = 0.7, 0.35, 0.4, 0.1, 10.0, 20.0
    p = Sine(kind="sine", channel="joint_2", amplitude=A, frequency=f, phase=ph, offset=off, start=t0,
             stop=t1)
    t = np.linspace(t0, t1 - 1e-6, 37)
    expected = off + A * np.sin(2 * math.pi * f * (t - t0) + ph)
    np.testing.assert_allclose(_u([p], t)[J2], expected, rtol=0, atol=1e-13)
    # the offset too is switched: zero outside the window
    np.testing.assert_array_equal(_u([p], [0.0, t0 - 1e-9, t1, 30.0])[J2], 0.0)


def test_chirp_phase_is_quadratic_in_time():
    A, f0, f1, ph, t0, t1 = 2.0, 0.1, 1.3, -0.3, 5.0, 65.0
    p = Chirp(kind="chirp", channel="force_x", amplitude=A, f0=f0, f1=f1, phase=ph, start=t0, stop=t1)
    t = np.linspace(t0, t1, 241)[:-1]
    tau = t - t0
    rate = (f1 - f0) / (t1 - t0)
    expected = A * np.sin(2 * math.pi * (f0 * tau + 0.5 * rate * tau**2) + ph)
    np.testing.assert_allclose(_u([p], t)[FX], expected, rtol=0, atol=1e-12)
    # the instantaneous frequency reaches f1 at the stop: the phase increment over the last 1 ms
    d = 1e-3
    phase = lambda tt: 2 * math.pi * (f0 * (tt - t0) + 0.5 * rate * (tt - t0) ** 2)  # noqa: E731
    assert (phase(t1) - phase(t1 - d)) / (2 * math.pi * d) == pytest.approx(f1, rel=1e-4)
    np.testing.assert_array_equal(_u([p], [t0 - 1e-9, t1])[FX], 0.0)


def test_table_interpolates_and_holds_its_ends_inside_the_window():
    p = Table(kind="table", channel="force_x", t=(1.0, 2.0, 4.0), value=(1.0, 3.0, -1.0), start=0.5, stop=6.0)
    t = [0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 3.5, 4.0, 5.0, 6.0]
    # before 0.5 and from 6.0 on: outside the window; 0.5..1: the first value held; 4..6: the last
    np.testing.assert_allclose(_u([p], t)[FX], [0.0, 1.0, 1.0, 2.0, 3.0, 1.0, 0.0, -1.0, -1.0, 0.0], rtol=0,
                               atol=1e-15)
    np.testing.assert_allclose(_u([p], [0.5, 6.0], left=True)[FX], [0.0, -1.0])


def test_profiles_on_one_channel_add_up_and_others_stay_zero():
    a = Step(kind="step", channel="joint_2", amplitude=1.0, start=0.0, stop=2.0)
    b = Step(kind="step", channel="joint_2", amplitude=0.25, start=1.0)
    c = Sine(kind="sine", channel="torque_z", amplitude=1.0, frequency=0.25, start=0.0)
    u = _u([a, b, c], [0.5, 1.5, 2.5])
    np.testing.assert_allclose(u[J2], [1.0, 1.25, 0.25])
    np.testing.assert_allclose(u[TZ], np.sin(2 * math.pi * 0.25 * np.array([0.5, 1.5, 2.5])), atol=1e-15)
    assert not np.any(np.delete(u, [J2, TZ], axis=0))


def test_disabled_or_empty_schedule_is_zero():
    p = Step(kind="step", channel="force_x", amplitude=1.0)
    np.testing.assert_array_equal(InputSchedule([p], 1, enabled=False).sample([0.0, 1.0]), np.zeros((7, 2)))
    np.testing.assert_array_equal(InputSchedule([], 0)(3.0), np.zeros(6))
    assert InputSchedule([], 0).sample([]).shape == (6, 0)


def test_the_compiled_model_assembles_the_same_inputs(envisat):
    """``pc_inputs`` (the model's path, what the integrators and FMUs use) equals the schedule, left
    limits included, around every switch of the scenario's excitation."""
    system = build_system(envisat)
    plant = CompiledPlant(system)
    switches = system.inputs.switching_times()
    assert switches
    t = np.unique(np.concatenate([[0.0], switches, np.add.outer(switches, [-1e-3, 1e-3]).ravel()]))
    t = t[t >= 0.0]
    for left in (False, True):
        u = system.inputs.sample(t, left=left)
        for k, tk in enumerate(t):
            np.testing.assert_array_equal(plant.inputs(tk, left), u[:, k])
    assert np.any(system.inputs.sample(t))
