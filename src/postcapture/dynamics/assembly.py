"""Build the multibody tree of a scenario (:class:`~postcapture.dynamics.tree.Tree`, plain data).

The tree: a free-flyer root for the chaser bus (joint ``chaser``, frame B); its panels (a root torsion
hinge about the panel's x axis, then one bending hinge about y per segment); the arm joints (each
optionally with a Spong rotor joint beside it); the target hub rigidly appended to the last arm link;
the target's panels. Springs and dampers are not part of the tree: they are collected here
as a :class:`SpringSet` and added as joint torques by the compiled core.

Variants: ``flexible`` (as described), ``stiff`` (every spring k = 1e7 N m/rad, the reference's
"rigid" mimic), ``rigid`` (every joint but the root locked at rest, :func:`~postcapture.dynamics.tree.lock_joints`).
The tests build the same trees with Pinocchio's own API and hold these to them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.config.schema import Panel, Scenario
from postcapture.dynamics.bodies import MassProperties, hub_properties, panel_properties, segment_properties
from postcapture.dynamics.parameters import dynamic_parameters
from postcapture.dynamics.tree import Tree, TreeBuilder, compose, lock_joints

__all__ = ["STIFF_K", "PanelLayout", "Layout", "SpringSet", "Assembly", "assemble", "assemble_panel_chain"]

STIFF_K = 1.0e7  # N m/rad, the reference's stiffness for its "rigid" model
_AXES = {"x": "rx", "y": "ry", "z": "rz"}


@dataclass(frozen=True)
class PanelLayout:
    """Where one panel lives in the model."""

    name: str
    host: str  # "chaser" or "target"
    length: float
    segments: int
    torsion_v: int | None  # velocity index of the root torsion hinge (None when locked)
    bending_v: tuple[int, ...]  # velocity indices of the bending hinges, root to tip
    root_frame: str
    tip_frame: str


@dataclass(frozen=True)
class Layout:
    """Index maps of a built model: which velocity coordinates and frames are which."""

    variant: str
    free_flyer: bool  # False for a chain on a fixed base (panel calibration)
    n_arm: int
    arm_v: tuple[int, ...]  # link-side arm joint velocity indices (empty when rigid)
    motor_v: tuple[int, ...]  # where each motor torque acts (rotor, or the link joint)
    rotor_v: tuple[int | None, ...]
    panels: tuple[PanelLayout, ...]
    has_target: bool
    target_panel_mass: float  # kg, total mass of the target's panels
    target_hub: MassProperties | None  # in the T frame


@dataclass(frozen=True)
class SpringSet:
    """Linear springs and dampers on the elastic coordinates ``e`` (all coordinates but the root's).

    Spring j has deflection ``a_j . e - r_j``, stiffness ``k_j`` and damping ``d_j`` on ``a_j . de/dt``.
    ``groups[j]`` says which scale of the parameter vector (:mod:`postcapture.dynamics.parameters`)
    multiplies it: ``(panel index, "bending" | "torsion")``, ``"arm"``, or None (a Spong servo).
    Immutable: :meth:`add` returns a new set.
    """

    rows: tuple = ()
    k: tuple = ()
    d: tuple = ()
    rest: tuple = ()
    names: tuple = ()
    groups: tuple = ()

    def add(self, name: str, row: dict[int, float], k: float, d: float, rest: float = 0.0, group=None) -> "SpringSet":
        """This set with one more spring-damper."""
        return SpringSet(self.rows + (tuple(sorted(row.items())),), self.k + (float(k),), self.d + (float(d),),
                         self.rest + (float(rest),), self.names + (name,), self.groups + (group,))

    def without_damping(self) -> "SpringSet":
        """The same springs with every damper zero."""
        return SpringSet(self.rows, self.k, (0.0,) * len(self.d), self.rest, self.names, self.groups)

    def matrix(self, n_e: int) -> np.ndarray:
        """The matrix A with rows a_j, shape (n_springs, n_e)."""
        A = np.zeros((len(self.rows), n_e))
        for j, row in enumerate(self.rows):
            for i, c in row:
                A[j, i] = c
        return A


@dataclass(frozen=True)
class Assembly:
    """The tree, its layout and springs: what :class:`~postcapture.dynamics.system.System` is built from."""

    tree: Tree
    layout: Layout
    springs: SpringSet
    q_rest: np.ndarray  # configuration with every joint at rest and the root at the origin


def _pose(pose) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(pose.rotation(), dtype=float), np.asarray(pose.translation(), dtype=float)


def _inertia(props: MassProperties) -> np.ndarray:
    return dynamic_parameters(props)


_I3, _O3 = np.eye(3), np.zeros(3)


class _Builder:
    def __init__(self, name: str, stiff: bool, scenario: Scenario | None = None, n_root: int = 6):
        self.sc = scenario
        self.stiff = stiff
        self.tree = TreeBuilder(name)  # no gravity: in orbit the whole stack is in free fall
        self.springs = SpringSet()
        self.rest: dict[int, float] = {}  # joint index -> rest angle
        self.n_root = n_root  # velocity coordinates of the root joint
        self.nv = 0  # velocity coordinates so far
        self.iv: dict[int, int] = {}  # joint index -> velocity index
        self.n_panels = 0  # panels built so far (their index in the parameter vector)

    def k(self, value: float) -> float:
        return STIFF_K if self.stiff else value

    def joint(self, parent: int, kind: str, placement, name: str, inertia=None) -> int:
        jid = self.tree.add_joint(parent, kind, placement[0], placement[1], name, inertia)
        self.iv[jid] = self.nv
        self.nv += 6 if kind == "free_flyer" else 1
        return jid

    def frame(self, name: str, joint: int, placement) -> None:
        self.tree.add_frame(name, joint, placement[0], placement[1])

    def e(self, jid: int) -> int:
        """Elastic-coordinate index of a revolute joint (its velocity index minus the root's)."""
        return self.iv[jid] - self.n_root

    def spring(self, name: str, row: dict, k: float, d: float, rest: float = 0.0, group=None) -> None:
        self.springs = self.springs.add(name, row, k, d, rest, group)

    def panel(self, host_joint: int, mount, panel: Panel, host: str) -> dict:
        n = panel.segments
        l = panel.length / n
        seg = _inertia(segment_properties(panel))
        self.frame(f"{panel.name}_root", host_joint, mount)
        tor = self.joint(host_joint, "rx", mount, f"{panel.name}_torsion")
        index = self.n_panels
        self.n_panels += 1
        self.spring(f"{panel.name}_torsion", {self.e(tor): 1.0}, self.k(panel.torsion_stiffness),
                    panel.damping_beta * panel.torsion_stiffness, group=(index, "torsion"))
        parent, bend = tor, []
        for i in range(n):
            jid = self.joint(parent, "ry", (_I3, [l if i else 0.0, 0.0, 0.0]), f"{panel.name}_bend_{i + 1}", seg)
            k_i = panel.bending_stiffness[i]
            self.spring(f"{panel.name}_bend_{i + 1}", {self.e(jid): 1.0}, self.k(k_i), panel.damping_beta * k_i,
                        group=(index, "bending"))
            bend.append(jid)
            parent = jid
        self.frame(f"{panel.name}_tip", parent, (_I3, [l, 0.0, 0.0]))
        return {"name": panel.name, "host": host, "length": panel.length, "segments": n, "torsion": tor, "bending": bend}

    def chaser(self):
        chaser = self.sc.chaser
        c_mounts = [(p.mount.rotation(), p.mount.translation(), panel_properties(p)) for p in chaser.panels]
        if chaser.properties_include_panels:
            c_hub = hub_properties(chaser.mass, chaser.inertia, c_mounts, "chaser")
        else:
            c_hub = MassProperties(chaser.mass, np.zeros(3), chaser.inertia)
        root = self.joint(-1, "free_flyer", (_I3, _O3), "chaser", _inertia(c_hub))
        self.frame("accelerometer", root, (_I3, chaser.accelerometer_position))
        return root, [self.panel(root, _pose(p.mount), p, "chaser") for p in chaser.panels]

    def arm_joint(self, i: int, js, parent: int):
        placement = _pose(js.origin)
        if i == 0:
            placement = compose(*_pose(self.sc.arm.base), *placement)
        rotor = None
        if js.rotor_inertia is not None:
            axis = np.eye(3)["xyz".index(js.axis)]
            rotor_I = _inertia(MassProperties(0.0, np.zeros(3), js.rotor_inertia * np.outer(axis, axis)))
            rotor = self.joint(parent, _AXES[js.axis], placement, f"arm_{i + 1}_rotor", rotor_I)
        link_I = _inertia(MassProperties(js.mass, js.com, js.inertia))
        jid = self.joint(parent, _AXES[js.axis], placement, f"arm_{i + 1}", link_I)
        self.rest[jid] = js.rest_angle
        if rotor is None:
            self.spring(f"arm_{i + 1}", {self.e(jid): 1.0}, self.k(js.stiffness), js.damping, js.rest_angle, group="arm")
        else:
            self.rest[rotor] = js.rest_angle
            self.spring(f"arm_{i + 1}", {self.e(jid): 1.0, self.e(rotor): -1.0}, self.k(js.stiffness), js.damping,
                        group="arm")
            ks = js.servo_stiffness if js.servo_stiffness is not None else js.stiffness
            ds = js.servo_damping if js.servo_damping is not None else js.damping
            self.spring(f"arm_{i + 1}_servo", {self.e(rotor): 1.0}, self.k(ks), ds, js.rest_angle)
        return jid, rotor

    def target(self, last: int, tool):
        tg = self.sc.target
        X_JT = compose(*tool, *_pose(tg.grasp_to_com))
        t_mounts = [(p.mount.rotation(), p.mount.translation(), panel_properties(p)) for p in tg.panels]
        if tg.properties_include_panels:
            hub = hub_properties(tg.mass, tg.inertia, t_mounts, "target")
        else:
            hub = MassProperties(tg.mass, np.zeros(3), tg.inertia)
        self.tree.append_inertia(last, _inertia(hub), *X_JT)
        self.frame("target", last, X_JT)
        panels = [self.panel(last, compose(*X_JT, *_pose(p.mount)), p, "target") for p in tg.panels]
        return hub, sum(p.mass for p in tg.panels), panels

    def build(self):
        sc = self.sc
        root, panels = self.chaser()
        arm_j, rotor_j = [], []
        target_hub, target_panel_mass = None, 0.0
        if sc.arm is not None:
            parent = root
            for i, js in enumerate(sc.arm.joints):
                parent, rotor = self.arm_joint(i, js, parent)
                arm_j.append(parent)
                rotor_j.append(rotor)
            tool = _pose(sc.arm.tool)
            self.frame("grasp", parent, tool)
            if sc.target is not None:
                target_hub, target_panel_mass, more = self.target(parent, tool)
                panels += more
        tree = self.tree.build()
        q_rest = tree.neutral()
        for jid, angle in self.rest.items():
            q_rest[tree.joints[jid].iq] = angle
        return tree, panels, arm_j, rotor_j, target_hub, target_panel_mass, q_rest


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


def _panel_layouts(tree: Tree, panels: list, locked: bool) -> tuple:
    def v(jid):
        return None if jid is None else tree.joints[jid].iv

    return tuple(
        PanelLayout(p["name"], p["host"], p["length"], p["segments"], None if locked else v(p["torsion"]),
                    () if locked else tuple(v(j) for j in p["bending"]), f"{p['name']}_root", f"{p['name']}_tip")
        for p in panels
    )


def assemble(scenario: Scenario, variant: str = "flexible") -> Assembly:
    """Build the multibody model of ``scenario`` in the given variant.

    Parameters
    ----------
    scenario : Scenario
        A validated scenario.
    variant : {"flexible", "stiff", "rigid"}
        ``stiff`` sets every spring to ``STIFF_K``; ``rigid`` locks every joint but the root.

    Returns
    -------
    Assembly
    """
    if variant not in ("flexible", "stiff", "rigid"):
        raise ValueError(f"variant: expected one of flexible, stiff, rigid, found {variant!r}")
    b = _Builder(scenario.name, stiff=(variant == "stiff"), scenario=scenario)
    tree, panels, arm_j, rotor_j, target_hub, t_panel_mass, q_rest = b.build()
    springs = b.springs
    motor_j = [r if r is not None else j for j, r in zip(arm_j, rotor_j)]
    rigid = variant == "rigid"
    layout_panels = _panel_layouts(tree, panels, rigid)

    def v(jid):
        return None if jid is None else tree.joints[jid].iv

    arm_v = () if rigid else tuple(v(j) for j in arm_j)
    motor_v = () if rigid else tuple(v(j) for j in motor_j)
    rotor_v = () if rigid else tuple(v(j) for j in rotor_j)
    if rigid:
        tree = lock_joints(tree, q_rest)
        springs = SpringSet()
        q_rest = tree.neutral()
    layout = Layout(
        variant=variant,
        free_flyer=True,
        n_arm=scenario.n_arm,
        arm_v=arm_v,
        motor_v=motor_v,
        rotor_v=rotor_v,
        panels=layout_panels,
        has_target=scenario.target is not None,
        target_panel_mass=t_panel_mass,
        target_hub=target_hub,
    )
    return Assembly(tree=tree, layout=layout, springs=springs, q_rest=_frozen(q_rest))


def assemble_panel_chain(panel: Panel, variant: str = "flexible") -> Assembly:
    """One panel cantilevered on a fixed base: the chain of :func:`assemble`, without the spacecraft.

    It is built by the same code as the full model, so what a calibration fits is what is simulated.
    """
    if variant not in ("flexible", "stiff"):
        raise ValueError(f"variant: expected flexible or stiff for a panel chain, found {variant!r}")
    b = _Builder(panel.name, stiff=(variant == "stiff"), n_root=0)
    p = b.panel(-1, (_I3, _O3), panel, "base")
    tree = b.tree.build()
    layout = Layout(
        variant=variant,
        free_flyer=False,
        n_arm=0,
        arm_v=(),
        motor_v=(),
        rotor_v=(),
        panels=_panel_layouts(tree, [p], False),
        has_target=False,
        target_panel_mass=0.0,
        target_hub=None,
    )
    return Assembly(tree=tree, layout=layout, springs=b.springs, q_rest=_frozen(tree.neutral()))
