"""Resource limits: estimates made before allocating, refusals that name the limit and how to raise it."""

import subprocess
import sys
import textwrap
import time

import pytest

from postcapture.config.limits import (
    CPU_VARIABLE,
    MEMORY_VARIABLE,
    Limits,
    check_resources,
    degrees_of_freedom,
    estimate_model,
    estimate_run,
    estimate_simulation,
)
from postcapture.core.errors import ResourceLimitError, ScenarioError
from postcapture.dynamics.build import build_system
from postcapture.dynamics.simulate import simulate


@pytest.mark.parametrize("variant", ["flexible", "stiff", "rigid"])
@pytest.mark.parametrize("segments", [None, 3, 8])
def test_degrees_of_freedom_match_the_built_model(envisat, variant, segments):
    assert degrees_of_freedom(envisat, variant, segments) == build_system(envisat, variant, panel_segments=segments).nv


def test_degrees_of_freedom_count_spong_rotors(envisat):
    arm = envisat.arm.model_dump()
    for joint in arm["joints"][:3]:
        joint.update(rotor_inertia=0.5, servo_stiffness=1e4, servo_damping=10.0)
    sc = envisat.with_updates(arm=arm)
    assert degrees_of_freedom(sc) == build_system(sc).nv == 25 + 3


def test_history_memory_is_what_a_trajectory_holds(envisat):
    traj = simulate(envisat, duration=30.0)
    held = traj.q.nbytes + traj.v.nbytes + traj.ddq.nbytes + sum(a.nbytes for a in traj.outputs.values())
    est = estimate_simulation(nv=25, duration=30.0, step=0.1, sample_period=0.1)
    model = estimate_model(25).memory
    assert 0.9 < ((est.memory - model) / 2) / held < 1.1  # histories counted twice (arrays and the file's copy)


def test_model_memory_estimate_bounds_the_measured_growth():
    """The peak memory of building an 80-segment model (175 DoF), measured in a fresh process."""
    code = textwrap.dedent("""
        from postcapture.config import load_scenario
        from postcapture.dynamics.build import build_system
        from postcapture.dynamics.core import CompiledPlant

        def peak():  # the process's peak virtual and resident sizes (bytes)
            fields = dict(line.split(":", 1) for line in open("/proc/self/status"))
            return [int(fields[k].split()[0]) * 1024 for k in ("VmPeak", "VmHWM")]

        sc = load_scenario("envisat")
        CompiledPlant(build_system(sc, panel_segments=2))  # imports and a small model first
        before = peak()
        plant = CompiledPlant(build_system(sc, panel_segments=80))  # the description and one instance in the core
        nv = plant.nv
        print(nv, *(a - b for a, b in zip(peak(), before)))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    nv, virtual, resident = (float(x) for x in done.stdout.split())
    assert nv == 175
    assert 0.7 < estimate_model(175).memory / virtual < 3.0, (virtual, resident)


def test_cpu_estimate_has_the_right_order(envisat):
    t0 = time.process_time()
    simulate(envisat, duration=10.0)
    cpu = time.process_time() - t0
    est = estimate_simulation(nv=25, duration=10.0, step=0.1, sample_period=0.1)
    assert 0.05 < est.cpu_seconds / cpu < 20, (est.cpu_seconds, cpu)


@pytest.mark.parametrize(
    ("kwargs", "limit", "variable"),
    [
        (dict(duration=1e12), "memory", MEMORY_VARIABLE),  # 1e13 samples: petabytes
        (dict(duration=300.0, step=1e-9, sample_period=1e-9), "memory", MEMORY_VARIABLE),
        (dict(duration=300.0, step=1e-9), "time", CPU_VARIABLE),  # 3e11 implicit steps
        # 135 DoF, 3e7 implicit steps of about 0.3 ms each (a few samples: time, not memory)
        (dict(duration=3e6, sample_period=1000.0, panel_segments=60), "time", CPU_VARIABLE),
    ],
)
def test_absurd_runs_are_refused_before_allocating(envisat, kwargs, limit, variable, monkeypatch):
    monkeypatch.setenv(CPU_VARIABLE, "0.5")
    monkeypatch.setenv(MEMORY_VARIABLE, "8G")
    t0 = time.perf_counter()
    with pytest.raises(ResourceLimitError, match=rf"would .* the limit is .*{variable}=") as err:
        simulate(envisat, **kwargs)
    assert err.value.limit == limit and err.value.needed > err.value.allowed
    assert time.perf_counter() - t0 < 10  # refused, not attempted


def test_the_limit_names_its_source_and_can_be_raised():
    est = estimate_simulation(nv=25, duration=1e7, step=0.1, sample_period=100.0)  # ~1.7 h CPU, 16 MB
    check_resources(est, Limits.from_environment({}))
    with pytest.raises(ResourceLimitError, match=rf"the limit is 1 h \({CPU_VARIABLE}=1\)"):
        check_resources(est, Limits.from_environment({CPU_VARIABLE: "1"}))
    with pytest.raises(ResourceLimitError, match=rf"the limit is 1 MiB \({MEMORY_VARIABLE}=1M\)"):
        check_resources(est, Limits.from_environment({MEMORY_VARIABLE: "1M"}))
    assert Limits.from_environment({MEMORY_VARIABLE: "64G"}).max_memory == 64 * 2**30
    assert Limits.from_environment({MEMORY_VARIABLE: "1e9"}).max_memory == 1e9


@pytest.mark.parametrize("value", ["lots", "-1G", "0", "nan", "inf"])
def test_bad_limit_values_are_named(value):
    with pytest.raises(ScenarioError, match=rf"{MEMORY_VARIABLE}: expected a positive number of bytes"):
        Limits.from_environment({MEMORY_VARIABLE: value})
    with pytest.raises(ScenarioError, match=rf"{CPU_VARIABLE}: expected a positive number of hours"):
        Limits.from_environment({CPU_VARIABLE: value})


def test_run_and_campaign_estimates_grow_with_cases_and_runs(envisat):
    one = estimate_run(envisat, n_cases=1)
    five = estimate_run(envisat, n_cases=5)
    campaign = estimate_run(envisat, n_cases=5, runs=100)
    assert one.memory < five.memory < campaign.memory and one.cpu_seconds < five.cpu_seconds
    assert campaign.cpu_seconds == pytest.approx(100 * five.cpu_seconds)
    assert "campaign of 100 runs" in campaign.what
