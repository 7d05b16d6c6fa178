"""The exported FMU: valid, fast to build, and its trajectory is the native one."""

import zipfile

import numpy as np

import fmpy

from fmi_helpers import rel  # noqa: E402

from postcapture.dynamics.build import build_system, initial_state  # noqa: E402
from lie_oracle import make_integrator  # noqa: E402
from postcapture.dynamics.outputs import OutputRecorder  # noqa: E402
from postcapture.dynamics.simulate import simulate_system  # noqa: E402
from postcapture.fmi.mapping import Mapping  # noqa: E402

DURATION = 20.0  # s: covers the joint sines (from 10 s) and the thruster ramps (from 20 s)


def test_export_time_and_contents(envisat_fmu):
    assert envisat_fmu.seconds < 60.0, f"export took {envisat_fmu.seconds:.1f} s"
    with zipfile.ZipFile(envisat_fmu.path) as zf:
        names = set(zf.namelist())
    ident = envisat_fmu.model_identifier
    assert {
        "modelDescription.xml",
        f"binaries/linux64/{ident}.so",
        "resources/postcapture_mapping.toml",
        "sources/pc_model.c",
        "sources/pc_fmi2.c",
    } <= names
    assert not any(n.endswith(".py") for n in names)
    mapping = Mapping.from_toml(envisat_fmu.mapping_path)
    assert mapping.kinematics == "free_flyer" and len(mapping.state) == envisat_fmu.n_states


def test_validate_reports_no_problem(envisat_fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(envisat_fmu.path)) == []


def test_model_description(envisat_fmu, envisat):
    md = fmpy.read_model_description(str(envisat_fmu.path))
    cs = md.coSimulation
    assert cs.providesDirectionalDerivative and cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    assert cs.canHandleVariableCommunicationStepSize
    var = {v.name: v for v in md.modelVariables}
    names = build_system(envisat).parameter_names
    for name in names:  # the parameter vector: inputs, so that their partials are directional derivatives
        assert (var[name].causality, var[name].variability) == ("input", "continuous"), name
    assert "target_mass" not in var
    assert var["target.m"].unit == "kg" and var["arm.stiffness_scale"].unit == "1"
    assert var["target.I_xx"].unit == "kg.m2"
    assert var["force_x"].causality == "input" and var["joint_7"].unit == "N.m"
    assert var["accel_B_x"].unit == "m/s2" and var["q_BN_w"].causality == "output"
    assert var["x_corr[51]"].causality == "input" and var["reset"].causality == "input"
    assert len(md.derivatives) == envisat_fmu.n_states
    assert {u.variable.name for u in md.outputs} >= {"q[1]", "accel_B_z", "F[50,50]", f"G[50,{len(names)}]",
                                                    f"Hp[10,{len(names)}]", "jacobian_valid"}
    assert var["jacobian_valid"].variability == "discrete"


def test_model_structure_lists_every_dependency(envisat_fmu, envisat):
    """Every output, derivative and initial unknown carries its dependencies (OMSimulator spent 90 s at
    load on an FMU where none did); they name the knowns the FMU's own directional derivatives say."""
    md = fmpy.read_model_description(str(envisat_fmu.path))
    for group in (md.outputs, md.derivatives, md.initialUnknowns):
        assert group and all(u.dependencies is not None for u in group)
    deps = {u.variable.name: {d.name for d in u.dependencies} for u in md.outputs}
    init = {u.variable.name: {d.name for d in u.dependencies} for u in md.initialUnknowns}
    assert deps["F[1,1]"] == set() and deps["jacobian_valid"] == set() and deps["q[4]"] == set()
    assert deps["q_BN_w"] == {"q[4]", "q[5]", "q[6]", "q[7]"}
    assert {"force_x", "joint_3", "target.m", "arm.stiffness_scale", "v[20]", "q[20]"} <= deps["accel_B_x"]
    assert not {"x_corr[1]", "reset", "jacobian_request", "q[1]"} & deps["accel_B_x"]
    assert init["accel_B_x"] == deps["accel_B_x"] and init["der(v[3])"] == deps["accel_B_x"]
    assert init["der(q[9])"] == {"v[8]"}


def _fmu_trajectory(path, names):
    res = fmpy.simulate_fmu(str(path), stop_time=DURATION, output_interval=0.1, output=names)
    return res["time"], np.array([res[n] for n in names])


def test_simulate_fmu_matches_native(envisat, envisat_fmu):
    """Same integrator and internal step as a converged run of the Python oracle: 1e-8 agreement.

    The oracle's Newton iterations converge to round-off as the FMU's do; each block of the state and each
    output agrees to 1e-8 of its range. The FMU takes each 0.1 s communication step as whole internal steps.
    """
    system = build_system(envisat)
    q, v = initial_state(system)
    h = envisat_fmu.step
    per = int(round(0.1 / h))
    integ = make_integrator(system, envisat_fmu.integrator, newton_tol=1e-15, reuse_jacobian=1)
    n = int(round(DURATION / 0.1)) + 1
    rec = OutputRecorder(system, n)
    X = np.zeros((system.nq + system.nv, n))
    for k in range(n):
        for i in range(per if k else 0):
            q, v = integ.step(q, v, (k - 1) * 0.1 + i * h, h)
        X[:, k] = np.concatenate([q, v])
        rec.record(k, q, v, k * 0.1)
    names = [f"q[{i + 1}]" for i in range(system.nq)] + [f"v[{i + 1}]" for i in range(system.nv)]
    outs = ["q_BN", "omega_BN_B", "accel_B", "arm_q", "arm_ddq", "tip_envisat_wing"]
    comps = {
        "q_BN": "wxyz",
        "omega_BN_B": "xyz",
        "accel_B": "xyz",
        "tip_envisat_wing": "xyz",
        "arm_q": [str(i + 1) for i in range(7)],
        "arm_ddq": [str(i + 1) for i in range(7)],
    }
    out_names = [f"{o}_{c}" for o in outs for c in comps[o]]
    t, Y = _fmu_trajectory(envisat_fmu.path, names + out_names)
    assert np.array_equal(t, np.arange(n) * 0.1) or np.abs(t - np.arange(n) * 0.1).max() < 1e-12
    nq = system.nq
    blocks = {
        "position": slice(0, 3),
        "quaternion": slice(3, 7),
        "joint angles": slice(7, nq),
        "linear velocity": slice(nq, nq + 3),
        "angular velocity": slice(nq + 3, nq + 6),
        "joint rates": slice(nq + 6, None),
    }
    Ys = Y[: X.shape[0]]
    for label, b in blocks.items():  # each block relative to its size over the run
        assert rel(Ys[b], X[b]) <= 1e-8, label
    row = X.shape[0]
    for o in outs:
        ref = rec.values[o]
        got = Y[row : row + ref.shape[0]]
        row += ref.shape[0]
        assert rel(got, ref) <= 1e-8, o


def test_simulate_fmu_against_simulate_system(envisat, envisat_fmu):
    """Against the default native run: the same compiled core, default settings on both sides, the same
    internal step.

    The state, attitude, rates and chaser acceleration agree to 1e-12 of their ranges.
    """
    system = build_system(envisat)
    q0, v0 = initial_state(system)
    traj = simulate_system(system, q0, v0, DURATION, step=envisat_fmu.step, sample_period=0.1,
                           integrator=envisat_fmu.integrator)
    names = [f"q[{i + 1}]" for i in range(system.nq)] + [f"v[{i + 1}]" for i in range(system.nv)]
    extra = [
        "q_BN_w",
        "q_BN_x",
        "q_BN_y",
        "q_BN_z",
        "omega_BN_B_x",
        "omega_BN_B_y",
        "omega_BN_B_z",
        "accel_B_x",
        "accel_B_y",
        "accel_B_z",
    ]
    _, Y = _fmu_trajectory(envisat_fmu.path, names + extra)
    X = np.vstack([traj.q, traj.v])
    k = len(names)
    assert rel(Y[:k], X) <= 1e-12
    assert rel(Y[k : k + 4], traj["q_BN"]) <= 1e-12
    assert rel(Y[k + 4 : k + 7], traj["omega_BN_B"]) <= 1e-12
    assert rel(Y[k + 7 :], traj["accel_B"]) <= 1e-12


def test_rigid_export_is_small(rigid_plain_fmu):
    from fmpy.validation import validate_fmu

    md = fmpy.read_model_description(str(rigid_plain_fmu.path))
    assert not md.coSimulation.providesDirectionalDerivative
    assert "F[1,1]" not in {v.name for v in md.modelVariables}
    assert validate_fmu(str(rigid_plain_fmu.path)) == []
