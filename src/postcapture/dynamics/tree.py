"""The multibody tree as plain, immutable data: joints, their placements and inertias, named frames.

A :class:`Tree` is what the compiled core is packed from and what the tests hand to Pinocchio (their
independent reference): joint ``i`` has a parent (``-1``: the universe), a kind (``"free_flyer"``,
``"rx"``, ``"ry"``, ``"rz"``), a placement ``(R, p)`` in its parent joint's frame, a body inertia as ten
dynamic parameters in its own frame (``[m, m c, I about the origin]``, Pinocchio's
``Inertia.toDynamicParameters`` order) and its first configuration and velocity index. A frame is a
placement in a joint's frame. Joints are numbered depth first, parents before children.

:class:`TreeBuilder` assembles one; :func:`lock_joints` folds every joint but the root into it at a
configuration (the ``rigid`` variant). Arrays are read-only; nothing here changes a built tree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.dynamics.parameters import transform_matrix

__all__ = ["Joint", "Frame", "Tree", "TreeBuilder", "lock_joints", "axis_rotation", "compose"]

KINDS = ("free_flyer", "rx", "ry", "rz")


def _frozen(x, shape) -> np.ndarray:
    a = np.array(x, dtype=float).reshape(shape)
    a.flags.writeable = False
    return a


def axis_rotation(kind: str, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the joint axis of ``kind`` (``"rx"``, ``"ry"``, ``"rz"``)."""
    k = "xyz".index(kind[1])
    c, s = np.cos(angle), np.sin(angle)
    i, j = (k + 1) % 3, (k + 2) % 3
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def compose(R1, p1, R2, p2) -> tuple[np.ndarray, np.ndarray]:
    """The placement ``(R1, p1) * (R2, p2)``."""
    R1, p1 = np.asarray(R1, dtype=float), np.asarray(p1, dtype=float)
    return R1 @ np.asarray(R2, dtype=float), p1 + R1 @ np.asarray(p2, dtype=float)


@dataclass(frozen=True)
class Joint:
    """One joint and the body it carries (see the module docstring)."""

    name: str
    parent: int
    kind: str
    rotation: np.ndarray
    translation: np.ndarray
    inertia: np.ndarray
    iq: int
    iv: int

    @property
    def nq(self) -> int:
        return 7 if self.kind == "free_flyer" else 1

    @property
    def nv(self) -> int:
        return 6 if self.kind == "free_flyer" else 1


@dataclass(frozen=True)
class Frame:
    """A named placement in a joint's frame."""

    name: str
    joint: int
    rotation: np.ndarray
    translation: np.ndarray


@dataclass(frozen=True)
class Tree:
    """Joints (depth first) and named frames; ``nq``, ``nv`` their coordinate counts."""

    name: str
    joints: tuple[Joint, ...]
    frames: tuple[Frame, ...]

    @property
    def nq(self) -> int:
        return sum(j.nq for j in self.joints)

    @property
    def nv(self) -> int:
        return sum(j.nv for j in self.joints)

    def frame(self, name: str) -> Frame:
        """The frame called ``name`` (KeyError naming the known ones otherwise)."""
        for f in self.frames:
            if f.name == name:
                return f
        raise KeyError(f"frame {name!r}: not in the tree (frames: {', '.join(f.name for f in self.frames)})")

    def has_frame(self, name: str) -> bool:
        return any(f.name == name for f in self.frames)

    def joint_index(self, name: str) -> int:
        for i, j in enumerate(self.joints):
            if j.name == name:
                return i
        raise KeyError(f"joint {name!r}: not in the tree")

    def neutral(self) -> np.ndarray:
        """Every joint at zero, the free flyer at the origin with the identity quaternion (x, y, z, w)."""
        q = np.zeros(self.nq)
        for j in self.joints:
            if j.kind == "free_flyer":
                q[j.iq + 6] = 1.0
        return q


class TreeBuilder:
    """Assemble a :class:`Tree` joint by joint (parents first)."""

    def __init__(self, name: str):
        self.name = name
        self._joints: list[dict] = []
        self._frames: list[Frame] = []

    def add_joint(self, parent: int, kind: str, rotation, translation, name: str, inertia=None) -> int:
        """Add a joint placed at ``(rotation, translation)`` in ``parent`` (``-1``: the universe); its index."""
        if kind not in KINDS:
            raise ValueError(f"joint {name!r}: kind {kind!r}, expected one of {', '.join(KINDS)}")
        if not -1 <= parent < len(self._joints):
            raise ValueError(f"joint {name!r}: parent {parent}, expected -1 to {len(self._joints) - 1}")
        pi = np.zeros(10) if inertia is None else np.array(inertia, dtype=float).reshape(10)
        self._joints.append(dict(name=name, parent=parent, kind=kind, rotation=np.asarray(rotation, dtype=float),
                                 translation=np.asarray(translation, dtype=float), inertia=pi))
        return len(self._joints) - 1

    def append_inertia(self, joint: int, pi, rotation=None, translation=None) -> None:
        """Add a body of dynamic parameters ``pi`` (given in a frame placed at ``(rotation, translation)`` in
        the joint's frame, identity by default) to the joint's body."""
        pi = np.asarray(pi, dtype=float)
        if rotation is not None:
            pi = transform_matrix(rotation, translation) @ pi
        self._joints[joint]["inertia"] = self._joints[joint]["inertia"] + pi

    def add_frame(self, name: str, joint: int, rotation, translation) -> None:
        """Add a named frame placed at ``(rotation, translation)`` in joint ``joint``."""
        self._frames.append(Frame(name, joint, _frozen(rotation, (3, 3)), _frozen(translation, 3)))

    def build(self) -> Tree:
        joints, iq, iv = [], 0, 0
        for j in self._joints:
            joint = Joint(j["name"], j["parent"], j["kind"], _frozen(j["rotation"], (3, 3)),
                          _frozen(j["translation"], 3), _frozen(j["inertia"], 10), iq, iv)
            joints.append(joint)
            iq, iv = iq + joint.nq, iv + joint.nv
        return Tree(self.name, tuple(joints), tuple(self._frames))


def _placement_in_root(tree: Tree, j: int, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Placement of joint ``j``'s frame in joint 0's frame at configuration ``q`` (revolute joints only below 0)."""
    R, p = np.eye(3), np.zeros(3)
    while j > 0:
        J = tree.joints[j]
        Rj, pj = compose(J.rotation, J.translation, axis_rotation(J.kind, q[J.iq]), np.zeros(3))
        R, p = compose(Rj, pj, R, p)
        j = J.parent
    return R, p


def lock_joints(tree: Tree, q: np.ndarray) -> Tree:
    """The tree with every joint but the root locked at ``q``: their bodies join the root's body and their
    frames move to the root (as Pinocchio's ``buildReducedModel``)."""
    root = tree.joints[0]
    b = TreeBuilder(tree.name)
    r = b.add_joint(root.parent, root.kind, root.rotation, root.translation, root.name, root.inertia)
    for j in range(1, len(tree.joints)):
        R, p = _placement_in_root(tree, j, q)
        b.append_inertia(r, tree.joints[j].inertia, R, p)
    for f in tree.frames:
        R, p = _placement_in_root(tree, f.joint, q)
        b.add_frame(f.name, r, *compose(R, p, f.rotation, f.translation))
    return b.build()
