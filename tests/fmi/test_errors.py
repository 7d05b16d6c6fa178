"""Bad FMUs and mappings give typed errors naming the FMU, the call and the status."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

import fmpy  # noqa: F401 - the fmi extra is part of the test install

from tiny_fmu import MAPPING, build_tiny_fmu  # noqa: E402

from postcapture.core.errors import DimensionError, DomainError, FMIError  # noqa: E402
from postcapture.fmi import FMUProcessModel, Mapping, fmu_info  # noqa: E402


def test_missing_file(tmp_path):
    path = tmp_path / "nowhere.fmu"
    with pytest.raises(FMIError, match="no such file") as err:
        FMUProcessModel(path)
    assert err.value.fmu == str(path) and err.value.function == "open"


def test_not_an_fmu(tmp_path):
    path = tmp_path / "junk.fmu"
    path.write_text("not a zip")
    with pytest.raises(FMIError, match="modelDescription") as err:
        FMUProcessModel(path)
    assert err.value.function == "read_model_description"


def test_model_exchange_only(tiny_dir):
    path = build_tiny_fmu(tiny_dir, "me_only")
    with pytest.raises(FMIError, match="offers model-exchange; a process model needs the co-simulation") as err:
        FMUProcessModel(path)
    assert str(path) in str(err.value)
    assert not fmu_info(path)["mapping"]["satisfied"]


def test_mapping_names_a_missing_variable(tiny_dir, tmp_path):
    path = build_tiny_fmu(tiny_dir, "ok")
    bad = tmp_path / "bad.toml"
    bad.write_text(MAPPING.replace('"dw_y"', '"dw_yy"').replace('reset = "reset"', 'reset = "rest"'))
    with pytest.raises(FMIError, match="close matches: dw_y") as err:
        FMUProcessModel(path, mapping=bad)
    msg = str(err.value)
    assert "measurement.accel: no variable 'dw_yy'" in msg and "correction.reset: no variable 'rest'" in msg
    assert "close matches: reset" in msg and err.value.function == "mapping"


def test_malformed_mapping(tmp_path):
    with pytest.raises(FMIError, match=r"\[state\] attitude: expected at least 4 entries, found ") as err:
        Mapping.from_text(
            MAPPING.replace('attitude = ["q_w", "q_x", "q_y", "q_z"]', 'attitude = ["q_w"]'), "m.toml"
        )
    assert err.value.fmu == "m.toml"
    with pytest.raises(FMIError, match="kinematics: expected one of"):
        Mapping.from_text(MAPPING.replace('"quaternion"', '"euler"'))
    with pytest.raises(FMIError, match="not valid TOML"):
        Mapping.from_text("[state\n")


def test_no_mapping(tiny_dir, tmp_path):
    path = build_tiny_fmu(tiny_dir, "ok")
    lonely = tmp_path / "lonely.fmu"
    lonely.write_bytes(path.read_bytes())
    with pytest.raises(FMIError, match="no mapping") as err:
        FMUProcessModel(lonely)
    assert err.value.function == "mapping"


@pytest.mark.parametrize("kind, status", [("discard", "Discard"), ("error", "Error")])
def test_do_step_failure(tiny_dir, kind, status):
    path = build_tiny_fmu(tiny_dir, kind)
    with FMUProcessModel(path) as model:
        with pytest.raises(FMIError, match=f"fmi2DoStep returned {status}") as err:
            model.predict(model.initial_state(), 0.0, 0.1)
    assert err.value.status == status and err.value.function == "fmi2DoStep" and err.value.fmu == str(path)


def test_no_fmu_state_for_finite_differences(tiny_dir):
    path = build_tiny_fmu(tiny_dir, "nostate")
    with FMUProcessModel(path) as model:
        x0 = model.initial_state()
        assert model.predict(x0, 0.0, 0.1).x.shape == (7,)  # plain prediction needs no FMU state
        with pytest.raises(FMIError, match="canGetAndSetFMUstate is false") as err:
            model.predict(x0, 0.0, 0.1, jacobians=True)
    assert err.value.function == "fmi2GetFMUstate"


def test_states_cannot_be_set_after_initialisation(envisat_fmu, tmp_path):
    """Our FMU refuses fmi2SetReal on a state in step mode, as the standard requires.

    A mapping that would correct the state that way is refused before the FMU is even loaded: its
    corrections are outputs, not inputs.
    """
    from fmpy import extract, read_model_description

    from postcapture.fmi.slave import Buffer, RawSlave

    mapping = Mapping.from_toml(envisat_fmu.mapping_path)
    with pytest.raises(FMIError, match="also in state.variables: a variable plays one role only"):
        Mapping.from_dict({**mapping.to_dict(), "correction": {"inputs": list(mapping.state), "reset": "reset"}})
    md = read_model_description(str(envisat_fmu.path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = RawSlave(md, extract(str(envisat_fmu.path), str(tmp_path / "x")), str(envisat_fmu.path))
    try:
        with pytest.raises(FMIError, match="fmi2SetReal returned Error") as err:
            slave.set_real(Buffer([vr[mapping.state[0]]]))
        assert err.value.status == "Error"
    finally:
        slave.close()


def test_out_of_range_mass_and_bad_shapes(envisat_fmu):
    with FMUProcessModel(envisat_fmu.path) as model:
        with pytest.raises(DomainError, match="target_mass: expected more than the panels' 350"):
            model.mass = 100.0  # below the target panels' 350 kg: refused before it reaches the FMU
        with pytest.raises(DomainError, match="expected scales >= 0"):
            model.set_params(np.r_[model.params[:-1], -1.0])
        model.predict(model.initial_state(), 0.0, 0.1)  # the FMU was never in error
        with pytest.raises(DimensionError, match=r"x: expected shape \(51,\)"):
            model.predict(np.zeros(50), 0.0, 0.1)
    with pytest.raises(FMIError, match="closed"):
        model.predict(np.zeros(51), 0.0, 0.1)


def test_missing_extra_is_reported():
    code = textwrap.dedent("""
        import sys
        sys.modules["fmpy"] = None
        import postcapture.fmi as fmi
        from postcapture.core.errors import MissingExtraError
        for call in (lambda: fmi.export_fmu("envisat", "x.fmu"), lambda: fmi.FMUProcessModel("x.fmu")):
            try:
                call()
            except MissingExtraError as exc:
                print(exc.package, exc.extra)
    """)
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert out == ["fmpy", "fmi", "fmpy", "fmi"]
