"""Build the Pinocchio multibody tree of a scenario.

The tree: a free-flyer root for the chaser bus (joint ``chaser``, frame B); its panels (a root torsion
hinge about the panel's x axis, then one bending hinge about y per segment); the arm joints (each
optionally with a Spong rotor joint beside it); the target hub rigidly appended to the last arm link;
the target's panels. Springs and dampers are not part of the Pinocchio model: they are collected here
as a :class:`SpringSet` and added as joint torques by :class:`postcapture.dynamics.system.System`.

Variants: ``flexible`` (as described), ``stiff`` (every spring k = 1e7 N m/rad, the reference's
"rigid" mimic), ``rigid`` (every joint but the root locked, through ``pinocchio.buildReducedModel``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from postcapture.config.schema import Panel, Scenario
from postcapture.dynamics.bodies import MassProperties, hub_properties, panel_properties, segment_properties

__all__ = ["STIFF_K", "PanelLayout", "Layout", "SpringSet", "Assembly", "assemble", "assemble_panel_chain"]

STIFF_K = 1.0e7  # N m/rad, the reference's stiffness for its "rigid" model
_AXES = {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}


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


@dataclass
class SpringSet:
    """Linear springs and dampers on the elastic coordinates ``e`` (all coordinates but the root's).

    Spring j has deflection ``a_j . e - r_j``, stiffness ``k_j`` and damping ``d_j`` on ``a_j . de/dt``.
    ``groups[j]`` says which scale of the parameter vector (:mod:`postcapture.dynamics.parameters`)
    multiplies it: ``(panel index, "bending" | "torsion")``, ``"arm"``, or None (a Spong servo).
    """

    rows: list[dict[int, float]] = field(default_factory=list)
    k: list[float] = field(default_factory=list)
    d: list[float] = field(default_factory=list)
    rest: list[float] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    groups: list = field(default_factory=list)

    def add(self, name: str, row: dict[int, float], k: float, d: float, rest: float = 0.0, group=None) -> None:
        """Add one spring-damper."""
        self.names.append(name)
        self.rows.append(row)
        self.k.append(float(k))
        self.d.append(float(d))
        self.rest.append(float(rest))
        self.groups.append(group)

    def matrix(self, n_e: int) -> np.ndarray:
        """The matrix A with rows a_j, shape (n_springs, n_e)."""
        A = np.zeros((len(self.rows), n_e))
        for j, row in enumerate(self.rows):
            for i, c in row.items():
                A[j, i] = c
        return A


@dataclass
class Assembly:
    """The Pinocchio model, its layout and springs: what :class:`System` is built from."""

    model: pin.Model
    layout: Layout
    springs: SpringSet
    q_rest: np.ndarray  # configuration with every joint at rest and the root at the origin


def _se3(R, p) -> pin.SE3:
    return pin.SE3(np.asarray(R, dtype=float), np.asarray(p, dtype=float))


def _pose(pose) -> pin.SE3:
    return _se3(pose.rotation(), pose.translation())


def _inertia(props: MassProperties) -> pin.Inertia:
    return pin.Inertia(props.mass, props.com, props.inertia)


class _Builder:
    def __init__(self, name: str, stiff: bool, scenario: Scenario | None = None, n_root: int = 6):
        self.sc = scenario
        self.stiff = stiff
        self.model = pin.Model()
        self.model.name = name
        # In orbit the whole stack is in free fall: no gravity in the model (Pinocchio defaults to -9.81 z).
        self.model.gravity = pin.Motion.Zero()
        self.springs = SpringSet()
        self.rest: dict[int, float] = {}  # joint id -> rest angle
        self.body_frame: dict[int, int] = {0: 0}  # joint id -> its body frame (the universe's is 0)
        self.n_root = n_root  # velocity coordinates of the root joint
        self.n_panels = 0  # panels built so far (their index in the parameter vector)

    def k(self, value: float) -> float:
        return STIFF_K if self.stiff else value

    def joint(self, parent: int, jmodel, placement: pin.SE3, name: str, inertia: pin.Inertia | None) -> int:
        m = self.model
        jid = m.addJoint(parent, jmodel, placement, name)
        fid = m.addJointFrame(jid, self.body_frame.get(parent, 0))
        if inertia is not None:
            m.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
        self.body_frame[jid] = m.addBodyFrame(name + "_body", jid, pin.SE3.Identity(), fid)
        return jid

    def frame(self, name: str, joint: int, placement: pin.SE3) -> int:
        f = pin.Frame(name, joint, self.body_frame[joint], placement, pin.FrameType.OP_FRAME)
        return self.model.addFrame(f)

    def e(self, jid: int) -> int:
        """Elastic-coordinate index of a revolute joint (its velocity index minus the root's)."""
        return self.model.joints[jid].idx_v - self.n_root

    def panel(self, host_joint: int, mount: pin.SE3, panel: Panel, host: str) -> dict:
        n = panel.segments
        l = panel.length / n
        seg = _inertia(segment_properties(panel))
        self.frame(f"{panel.name}_root", host_joint, mount)
        tor = self.joint(host_joint, pin.JointModelRX(), mount, f"{panel.name}_torsion", None)
        kt = self.k(panel.torsion_stiffness)
        index = self.n_panels
        self.n_panels += 1
        self.springs.add(f"{panel.name}_torsion", {self.e(tor): 1.0}, kt, panel.damping_beta * panel.torsion_stiffness,
                         group=(index, "torsion"))
        parent, bend = tor, []
        for i in range(n):
            placement = _se3(np.eye(3), [l if i else 0.0, 0.0, 0.0])
            jid = self.joint(parent, pin.JointModelRY(), placement, f"{panel.name}_bend_{i + 1}", seg)
            k_i = panel.bending_stiffness[i]
            self.springs.add(f"{panel.name}_bend_{i + 1}", {self.e(jid): 1.0}, self.k(k_i), panel.damping_beta * k_i,
                             group=(index, "bending"))
            bend.append(jid)
            parent = jid
        self.frame(f"{panel.name}_tip", parent, _se3(np.eye(3), [l, 0.0, 0.0]))
        return {"name": panel.name, "host": host, "length": panel.length, "segments": n, "torsion": tor, "bending": bend}

    def build(self):
        sc = self.sc
        m = self.model
        chaser = sc.chaser
        c_mounts = [(p.mount.rotation(), p.mount.translation(), panel_properties(p)) for p in chaser.panels]
        if chaser.properties_include_panels:
            c_hub = hub_properties(chaser.mass, chaser.inertia, c_mounts, "chaser")
        else:
            c_hub = MassProperties(chaser.mass, np.zeros(3), chaser.inertia)
        root = self.joint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "chaser", _inertia(c_hub))
        self.frame("accelerometer", root, _se3(np.eye(3), chaser.accelerometer_position))
        panels = [self.panel(root, _pose(p.mount), p, "chaser") for p in chaser.panels]

        arm_j, rotor_j, motor_j = [], [], []
        target_hub, target_panel_mass = None, 0.0
        if sc.arm is not None:
            parent = root
            for i, js in enumerate(sc.arm.joints):
                placement = _pose(js.origin)
                if i == 0:
                    placement = _pose(sc.arm.base) * placement
                rotor = None
                if js.rotor_inertia is not None:
                    axis = np.eye(3)["xyz".index(js.axis)]
                    rotor_I = pin.Inertia(0.0, np.zeros(3), js.rotor_inertia * np.outer(axis, axis))
                    rotor = self.joint(parent, _AXES[js.axis](), placement, f"arm_{i + 1}_rotor", rotor_I)
                link_I = pin.Inertia(js.mass, np.asarray(js.com, dtype=float), np.asarray(js.inertia, dtype=float))
                jid = self.joint(parent, _AXES[js.axis](), placement, f"arm_{i + 1}", link_I)
                self.rest[jid] = js.rest_angle
                if rotor is None:
                    self.springs.add(f"arm_{i + 1}", {self.e(jid): 1.0}, self.k(js.stiffness), js.damping, js.rest_angle,
                                     group="arm")
                else:
                    self.rest[rotor] = js.rest_angle
                    row = {self.e(jid): 1.0, self.e(rotor): -1.0}
                    self.springs.add(f"arm_{i + 1}", row, self.k(js.stiffness), js.damping, group="arm")
                    ks = js.servo_stiffness if js.servo_stiffness is not None else js.stiffness
                    ds = js.servo_damping if js.servo_damping is not None else js.damping
                    self.springs.add(f"arm_{i + 1}_servo", {self.e(rotor): 1.0}, self.k(ks), ds, js.rest_angle)
                arm_j.append(jid)
                rotor_j.append(rotor)
                motor_j.append(rotor if rotor is not None else jid)
                parent = jid
            last = parent
            tool = _pose(sc.arm.tool)
            self.frame("grasp", last, tool)
            if sc.target is not None:
                tg = sc.target
                X_JT = tool * _pose(tg.grasp_to_com)
                t_mounts = [(p.mount.rotation(), p.mount.translation(), panel_properties(p)) for p in tg.panels]
                if tg.properties_include_panels:
                    target_hub = hub_properties(tg.mass, tg.inertia, t_mounts, "target")
                else:
                    target_hub = MassProperties(tg.mass, np.zeros(3), tg.inertia)
                target_panel_mass = sum(p.mass for p in tg.panels)
                m.appendBodyToJoint(last, X_JT.act(_inertia(target_hub)), pin.SE3.Identity())
                self.frame("target", last, X_JT)
                panels += [self.panel(last, X_JT * _pose(p.mount), p, "target") for p in tg.panels]

        q_rest = pin.neutral(m)
        for jid, angle in self.rest.items():
            q_rest[m.joints[jid].idx_q] = angle
        return root, panels, arm_j, rotor_j, motor_j, target_hub, target_panel_mass, q_rest


def _v(model: pin.Model, jid: int | None) -> int | None:
    return None if jid is None else model.joints[jid].idx_v


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
    root, panels, arm_j, rotor_j, motor_j, target_hub, t_panel_mass, q_rest = b.build()
    model = b.model
    springs = b.springs
    if variant == "rigid":
        locked = list(range(2, model.njoints))
        model = pin.buildReducedModel(model, locked, q_rest)
        model.gravity = pin.Motion.Zero()
        springs = SpringSet()
        q_rest = pin.neutral(model)
        layout_panels = tuple(
            PanelLayout(p["name"], p["host"], p["length"], p["segments"], None, (), f"{p['name']}_root", f"{p['name']}_tip")
            for p in panels
        )
        arm_v: tuple = ()
        motor_v: tuple = ()
        rotor_v: tuple = ()
    else:
        layout_panels = tuple(
            PanelLayout(
                p["name"], p["host"], p["length"], p["segments"], _v(model, p["torsion"]),
                tuple(_v(model, j) for j in p["bending"]), f"{p['name']}_root", f"{p['name']}_tip",
            )
            for p in panels
        )
        arm_v = tuple(_v(model, j) for j in arm_j)
        motor_v = tuple(_v(model, j) for j in motor_j)
        rotor_v = tuple(_v(model, j) for j in rotor_j)
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
    return Assembly(model=model, layout=layout, springs=springs, q_rest=q_rest)


def assemble_panel_chain(panel: Panel, variant: str = "flexible") -> Assembly:
    """One panel cantilevered on a fixed base: the chain of :func:`assemble`, without the spacecraft.

    It is built by the same code as the full model, so what a calibration fits is what is simulated.
    """
    if variant not in ("flexible", "stiff"):
        raise ValueError(f"variant: expected flexible or stiff for a panel chain, found {variant!r}")
    b = _Builder(panel.name, stiff=(variant == "stiff"), n_root=0)
    p = b.panel(0, pin.SE3.Identity(), panel, "base")
    layout = Layout(
        variant=variant,
        free_flyer=False,
        n_arm=0,
        arm_v=(),
        motor_v=(),
        rotor_v=(),
        panels=(
            PanelLayout(
                panel.name, "base", panel.length, panel.segments, _v(b.model, p["torsion"]),
                tuple(_v(b.model, j) for j in p["bending"]), f"{panel.name}_root", f"{panel.name}_tip",
            ),
        ),
        has_target=False,
        target_panel_mass=0.0,
        target_hub=None,
    )
    return Assembly(model=b.model, layout=layout, springs=b.springs, q_rest=pin.neutral(b.model))
