"""Mapping files, ``fmu_info`` and the tangent-space maps of the FMU process model."""

import numpy as np
import pinocchio as pin
import pytest
from tiny_fmu import MAPPING  # noqa: I001

from postcapture.fmi.kinematics import FreeFlyerKinematics, QuaternionKinematics
from postcapture.fmi.mapping import Mapping, check_mapping


def test_mapping_round_trip():
    m = Mapping.from_text(MAPPING, "tiny.toml")
    again = Mapping.from_text(m.to_toml())
    assert again.to_dict() == m.to_dict()
    assert m.n_meas == 3 and m.jacobians is None and m.mass is None


def test_check_mapping_lists_every_problem():
    m = Mapping.from_text(MAPPING)
    names = set(MAPPING.split('"')[1::2]) - {"w_z", "x_corr_7"} | {"w_zz"}
    problems = check_mapping(m, names, "tiny.fmu")
    assert any("state.variables: no variable 'w_z'" in p and "w_zz" in p for p in problems)
    assert any("correction.inputs: no variable 'x_corr_7'" in p for p in problems)


@pytest.mark.parametrize("kin_factory", ["free_flyer", "quaternion"])
def test_tangent_maps(kin_factory):
    rng = np.random.default_rng(3)
    if kin_factory == "free_flyer":
        kin = FreeFlyerKinematics(2 * 10 - 1)
        model = pin.Model()
        model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "ff")
        q = pin.randomConfiguration(model, -np.ones(7), np.ones(7))
        x = np.concatenate([q, rng.standard_normal(3), rng.standard_normal(9)])
    else:
        kin = QuaternionKinematics(9, [2, 3, 4, 5], [6, 7, 8])
        q = rng.standard_normal(4)
        x = np.concatenate([rng.standard_normal(2), q / np.linalg.norm(q), rng.standard_normal(3)])
    n = kin.n
    d = 0.2 * rng.standard_normal(n)
    np.testing.assert_allclose(kin.local(kin.retract(x, d), x), d, atol=1e-12)
    L, P = kin.basis(x), kin.projector(x)
    np.testing.assert_allclose(P @ L, np.eye(n), atol=1e-14)
    eps = 1e-6
    fd = np.column_stack(
        [(kin.retract(x, eps * e) - kin.retract(x, -eps * e)) / (2 * eps) for e in np.eye(n)]
    )
    np.testing.assert_allclose(L, fd, atol=1e-9)
    xdot = L @ rng.standard_normal(n)  # a rate tangent to the manifold
    Pd = kin.projector_rate(x, xdot)
    fd_rate = (kin.projector(x + eps * xdot) - kin.projector(x - eps * xdot)) / (2 * eps)
    np.testing.assert_allclose(Pd, fd_rate, atol=1e-8)


def test_fmu_info(envisat_fmu):
    from postcapture.fmi import fmu_info, format_fmu_info

    info = fmu_info(envisat_fmu.path)
    assert info["fmi_version"] == "2.0" and info["interfaces"] == ["co-simulation"]
    assert (
        info["capabilities"]["providesDirectionalDerivative"] and info["capabilities"]["canSerializeFMUstate"]
    )
    assert info["mapping"]["satisfied"] and info["mapping"]["jacobians"].startswith("outputs")
    assert {v["name"] for v in info["variables"]} >= {"target.m", "x_corr[1]", "F[50,50]", "G[50,18]"}
    text = format_fmu_info(info)
    assert "F[1..50,1..50]" in text and "der(q[1..26])" in text and "satisfied" in text
    _fits_80_columns_and_keeps_every_description(info, text)


def _fits_80_columns_and_keeps_every_description(info, text):
    assert max(len(line) for line in text.splitlines()) <= 80
    flat = " ".join(text.split())
    for v in info["variables"]:
        if v["description"] and "[" not in v["name"]:  # array families show their first description
            assert " ".join(v["description"].split()) in flat, v["name"]


def test_fmu_info_without_mapping(tiny_dir, tmp_path):
    from tiny_fmu import build_tiny_fmu

    from postcapture.fmi import fmu_info, format_fmu_info

    path = build_tiny_fmu(tiny_dir, "ok")
    lonely = tmp_path / "lonely.fmu"
    lonely.write_bytes(path.read_bytes())
    info = fmu_info(lonely)
    assert info["mapping"]["source"] is None and not info["mapping"]["satisfied"]
    assert "correction.reset" in format_fmu_info(info)
    _fits_80_columns_and_keeps_every_description(info, format_fmu_info(info))
    assert fmu_info(lonely, mapping=path.with_suffix(".toml"))["mapping"]["satisfied"]
