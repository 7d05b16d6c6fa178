"""The package's plain-numpy tree builder against the same tree built with Pinocchio's own API
(placements composed by SE3 products, the target hub moved by Inertia.act, the rigid variant by
buildReducedModel): every joint, inertia and frame."""

import numpy as np
import pinocchio as pin
import pinocchio_reference as ref
import pytest

from postcapture.config.schema import Scenario
from postcapture.dynamics.assembly import assemble

_KINDS = {"JointModelFreeFlyer": "free_flyer", "JointModelRX": "rx", "JointModelRY": "ry", "JointModelRZ": "rz"}


def _compare(tree, model):
    assert len(tree.joints) == model.njoints - 1
    for j, J in enumerate(tree.joints, start=1):
        assert J.name == model.names[j]
        assert J.parent + 1 == model.parents[j]
        assert J.kind == _KINDS[model.joints[j].shortname()]
        assert (J.iq, J.iv) == (model.joints[j].idx_q, model.joints[j].idx_v)
        M = model.jointPlacements[j]
        np.testing.assert_allclose(J.rotation, M.rotation, atol=1e-14)
        np.testing.assert_allclose(J.translation, M.translation, atol=1e-14)
        pi = model.inertias[j].toDynamicParameters()
        np.testing.assert_allclose(J.inertia, pi, rtol=1e-12, atol=1e-9 * max(1.0, np.abs(pi).max()))
    for f in tree.frames:
        F = model.frames[model.getFrameId(f.name)]
        assert f.joint + 1 == F.parentJoint
        np.testing.assert_allclose(f.rotation, F.placement.rotation, atol=1e-14)
        np.testing.assert_allclose(f.translation, F.placement.translation, atol=1e-12)


@pytest.mark.parametrize("variant", ["flexible", "stiff", "rigid"])
def test_envisat_tree_matches_pinocchio(envisat, variant):
    asm = assemble(envisat, variant)
    model, q_rest = ref.scenario_model(envisat, variant)
    _compare(asm.tree, model)
    np.testing.assert_allclose(asm.q_rest, q_rest, atol=0)


def test_tree_with_rotors_and_more_segments_matches_pinocchio(envisat):
    data = envisat.with_panel_segments(7).model_dump()
    for j in data["arm"]["joints"]:
        j["rotor_inertia"] = 0.5
    sc = Scenario.model_validate(data)
    model, _ = ref.scenario_model(sc)
    _compare(assemble(sc).tree, model)


def test_the_tree_is_read_only(envisat):
    tree = assemble(envisat).tree
    with pytest.raises(ValueError):
        tree.joints[0].inertia[0] = 1.0
    with pytest.raises(AttributeError):
        tree.joints[0].parent = 3
    assert pin.__version__  # the reference is installed (the test extra)
