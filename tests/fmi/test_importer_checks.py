"""The FMU importer refuses what it cannot run, before running it, with one message per problem.

Mappings are validated on their own (overlaps, duplicates, kinematics) and against the FMU's variables
(causality, variability, type); FMI 3.0 capability flags are read from the XML itself; interfaces other
than co-simulation are named; missing platform binaries are reported; after an FMU error the instance
refuses further calls, and the FMU's own message is in the error.
"""

import zipfile

import numpy as np
import pytest

import fmpy  # noqa: F401 - the fmi extra is part of the test install

from tiny_fmu import MAPPING, build_tiny_fmu, build_tiny_fmu3  # noqa: E402

from postcapture.core.errors import DomainError, FMIError  # noqa: E402
from postcapture.fmi import FMUProcessModel, Mapping, fmu_info, format_fmu_info  # noqa: E402
from postcapture.fmi.mapping import check_mapping, mapping_sidecar  # noqa: E402

OVERLAP = MAPPING.replace('rate = ["w_x", "w_y", "w_z"]', 'rate = ["q_z", "w_y", "w_z"]')


def test_rate_overlapping_the_attitude_is_refused_everywhere(tiny_dir, tmp_path):
    with pytest.raises(FMIError, match=r"'q_z' also in \[state\] attitude: the attitude and rate entries must not "
                                       r"overlap") as err:
        Mapping.from_text(OVERLAP, "overlap.toml")
    assert err.value.function == "mapping"
    path = build_tiny_fmu(tiny_dir, "ok")
    bad = tmp_path / "overlap.toml"
    bad.write_text(OVERLAP)
    info = fmu_info(path, mapping=bad)
    assert not info["mapping"]["satisfied"]
    assert any("must not overlap" in p for p in info["mapping"]["problems"])
    assert "NOT satisfied" in format_fmu_info(info)
    with pytest.raises(FMIError, match="must not overlap"):  # not a KeyError from the kinematics
        FMUProcessModel(path, mapping=bad)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda m: m.replace('"x_corr_1", "x_corr_2"', '"x_corr_1", "x_corr_1"'),
         r"\[correction\] inputs: 'x_corr_1' listed more than once"),
        (lambda m: m.replace('reset = "reset"', 'reset = "x_corr_7"'),
         r"correction.reset: 'x_corr_7' also in correction.inputs: a variable plays one role only"),
        (lambda m: m.replace('["q_w", "q_x", "q_y", "q_z"]\nrate', '["q_w", "q_x", "q_w", "q_z"]\nrate'),
         r"\[state\] attitude: 'q_w' listed more than once"),
        (lambda m: m + '[jacobians]\nrequest = "reset"\nF = "F[{i}]"\ng = "g[{i}]"\nH = "H[{i},{j}]"\nh = "h[{k}]"\n',
         r"\[jacobians\] F: expected a pattern holding \{i\} and \{j\}.*\n.*\[jacobians\] h: 'h\[\{k\}\]' is not a name"),
        (lambda m: m + "[correction2]\n", r"\[correction2\]: expected a known key"),
        (lambda m: m.replace('reset = "reset"', 'reset = "reset"\nrest = "x"'), r"\[correction\] rest: expected a known key.*\(did you mean 'reset'\?\)"),
    ],
)
def test_malformed_mappings_list_every_problem(change, message):
    with pytest.raises(FMIError, match=message):
        Mapping.from_text(change(MAPPING))


def test_mapping_checked_against_causality_and_variability(tiny_dir):
    path = build_tiny_fmu(tiny_dir, "ok")
    md = fmpy.read_model_description(str(path))
    text = (MAPPING.replace('accel = ["dw_x", "dw_y", "dw_z"]', 'accel = ["x_corr_1", "dw_y", "dw_z"]')
            .replace('"x_corr_2", "x_corr_3"', '"dw_x", "x_corr_3"')
            + '[parameters]\nmass = "dw_y"\n')
    problems = check_mapping(Mapping.from_text(text), md.modelVariables, str(path), 6)
    assert "correction.inputs: 'dw_x' has causality 'output' and variability 'continuous'; expected an input " \
           "(set before each step)" in problems
    assert any(p.startswith("measurement.accel: 'x_corr_1' has causality 'input'") and "readable output" in p
               for p in problems)
    assert any(p.startswith("parameters.mass: 'dw_y' has causality 'output'") and "a tunable parameter" in p
               for p in problems)
    assert len(problems) == 3, problems
    assert check_mapping(Mapping.from_text(MAPPING), md.modelVariables, str(path), 6) == []


def test_fmi3_capability_flags_come_from_the_xml(tiny_dir):
    plain = build_tiny_fmu3(tiny_dir)
    dd = build_tiny_fmu3(tiny_dir, flags=' providesDirectionalDerivatives="true"', name="tiny3dd")
    assert not fmpy.read_model_description(str(dd)).coSimulation.providesDirectionalDerivative  # FMPy drops it
    assert fmu_info(dd)["capabilities"]["providesDirectionalDerivative"]
    assert not fmu_info(plain)["capabilities"]["providesDirectionalDerivative"]
    assert fmu_info(dd)["capabilities"]["canGetAndSetFMUstate"]  # FMI 3 spells it canGetAndSetFMUState
    with FMUProcessModel(dd) as model:
        assert model.capabilities["provides_directional_derivative"]
    with FMUProcessModel(plain) as model:
        assert not model.capabilities["provides_directional_derivative"]


def test_scheduled_execution_is_named_as_such(tiny_dir):
    path = build_tiny_fmu3(tiny_dir, interface="ScheduledExecution", name="tiny3se")
    info = fmu_info(path)
    assert info["interfaces"] == ["scheduled-execution"]
    assert "FMI 3.0 scheduled-execution" in format_fmu_info(info)
    assert any("no co-simulation interface (it offers: scheduled-execution)" in p for p in info["mapping"]["problems"])
    with pytest.raises(FMIError, match="offers scheduled-execution; a process model needs the co-simulation "
                                       "interface .*scheduled execution are not supported"):
        FMUProcessModel(path)


def test_missing_platform_binary_is_reported(tiny_dir, tmp_path):
    path = build_tiny_fmu(tiny_dir, "ok")
    other = tmp_path / "windows_only.fmu"
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(other, "w") as dst:
        for item in src.infolist():
            if item.filename.startswith("binaries/"):
                dst.writestr("binaries/win64/tiny.dll", b"MZ")
            else:
                dst.writestr(item, src.read(item))
    mapping_sidecar(other).write_text(MAPPING)
    info = fmu_info(other)
    assert info["binaries"]["platforms"] == ["win64"]
    assert "no binary for this platform (linux64: expected binaries/linux64/tiny.so); platforms it has: win64" \
           in info["binaries"]["problem"]
    assert "ships C sources" in info["binaries"]["problem"]
    assert "NONE FOR THIS PLATFORM" in format_fmu_info(info) and not info["mapping"]["satisfied"]
    with pytest.raises(FMIError, match="no binary for this platform"):
        FMUProcessModel(other)
    assert fmu_info(path)["binaries"]["problem"] is None


def test_error_state_and_the_fmus_own_message(tiny_dir):
    with FMUProcessModel(build_tiny_fmu(tiny_dir, "error")) as model:
        x0 = model.initial_state()
        with pytest.raises(FMIError, match="fmi2DoStep returned Error: the call failed; the FMU said: tiny: failing "
                                           "on purpose"):
            model.predict(x0, 0.0, 0.1)
        with pytest.raises(FMIError, match="in the error state since fmi2DoStep returned Error; it can only be freed"):
            model.predict(x0, 0.1, 0.1)


def test_non_finite_inputs_are_refused_before_the_fmu(tiny_dir):
    with FMUProcessModel(build_tiny_fmu(tiny_dir, "ok")) as model:
        x = model.initial_state()
        x[5] = np.inf
        with pytest.raises(DomainError, match="x: expected finite values, found non-finite w_y"):
            model.predict(x, 0.0, 0.1)
        for t, dt in ((0.0, np.inf), (np.nan, 0.1), (0.0, 0.0), (0.0, -0.1)):
            with pytest.raises(DomainError, match="expected a finite time and a finite step > 0 s"):
                model.predict(model.initial_state(), t, dt)
        assert np.all(np.isfinite(model.predict(model.initial_state(), 0.0, 0.1).x))  # still usable


def test_exported_mapping_never_collides_with_the_fmu(envisat, tmp_path):
    """`fmu export -o plant.toml` used to write the mapping over the FMU it had just written."""
    from postcapture.fmi import export_fmu

    report = export_fmu(envisat, tmp_path / "plant.toml", variant="rigid", directional_derivatives=False,
                        step_jacobian=False)
    assert report.path == tmp_path / "plant.toml" and report.mapping_path == tmp_path / "plant.mapping.toml"
    assert zipfile.is_zipfile(report.path)
    assert Mapping.from_toml(report.mapping_path).state == Mapping.from_toml(mapping_sidecar(report.path)).state
    assert fmu_info(report.path)["mapping"]["satisfied"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plant.mapping.toml", "plant.toml"]
