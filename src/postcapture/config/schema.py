"""The scenario: typed, immutable description of the post-capture system and its run.

Frames: N inertial; B chaser body (origin at the chaser centre of mass); L_i arm link i (joint i
frame); G grasp frame on the arm's tool; T target body (origin at the target centre of mass);
P panel root frame (x along the panel length from root to tip, y across its width, z normal).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from postcapture.config.estimation import Estimation
from postcapture.config.excitation import Excitation, channel_index
from postcapture.config.faults import Fault, JointFault, fault_window
from postcapture.config.uncertainty import Uncertainty
from postcapture.config.flexibility import refine_stiffness
from postcapture.config.names import INTEGRATORS, MAX_SEGMENTS, PROFILES, VARIANTS
from postcapture.config.types import (
    Angle,
    AxisName,
    Damping,
    Duration,
    Frozen,
    Mass,
    Mat3,
    Name,
    Pose,
    Position3,
    Size,
    Stiffness,
    Text,
    check_inertia,
    problem,
    problems,
    quantity,
    vector,
)
from postcapture.core.errors import Problem, ScenarioError
from typing import Annotated

__all__ = [
    "fault_problems",
    "Panel",
    "Chaser",
    "Target",
    "ArmJoint",
    "Arm",
    "InitialState",
    "Simulation",
    "Orbit",
    "orbit_mean_motion",
    "Scenario",
    "INTEGRATORS",
    "VARIANTS",
    "MAX_SEGMENTS",
]

ARCSEC = 4.84813681109536e-06  # rad
VARIANTS = ("flexible", "stiff", "rigid")
MAX_SEGMENTS = 1000
"""Most segments a panel may be cut into (scenario files and :meth:`Panel.with_segments` alike)."""
MIN_SAMPLE_PERIOD = 1e-6  # s: shorter output periods are not a physical sensor's
Inertia = Annotated[Mat3, check_inertia, Field(json_schema_extra={
    "unit": "kg m^2", "bounds": "symmetric, positive definite, principal moments satisfying I1 + I2 >= I3, "
                                "entries of magnitude at most 1e10"})]


class Panel(Frozen):
    """A flexible rectangular panel: N rigid segments on bending hinges plus a root torsion hinge.

    ``bending_stiffness`` lists the N hinge stiffnesses from root to tip (N m/rad); for another
    number of segments use :meth:`with_segments`, which derives them from the piecewise-constant
    EI(s) they imply (see :mod:`postcapture.config.flexibility`).

    Attributes
    ----------
    name : str
        Unique among the spacecraft's panels; it names the panel's outputs (``tip_<name>``).
    mount : Pose
        The panel root frame P in the host body's frame (B for the chaser, T for the target).
    length, width : float
        Along x_P from root to tip, and across (m).
    mass : float
        The whole panel, spread evenly over its segments (kg).
    segments : int
        Rigid segments on bending hinges; the first hinge sits at the root.
    bending_stiffness : list of float
        One hinge stiffness per segment, root to tip (N m/rad); ``postcapture panel calibrate`` fits them.
    torsion_stiffness : float
        The root torsion hinge about x_P (N m/rad).
    damping_beta : float
        Stiffness-proportional damping, d = beta k on every hinge (s).
    """

    name: Name
    mount: Pose = Pose()
    length: Size
    width: Size
    mass: Mass
    segments: int = Field(ge=1, le=MAX_SEGMENTS)
    bending_stiffness: tuple[Stiffness, ...]
    torsion_stiffness: Stiffness
    damping_beta: quantity("s", ge=0.0, le=10.0) = 0.0  # stiffness-proportional damping d = beta k (s)

    @model_validator(mode="after")
    def _count(self):
        if len(self.bending_stiffness) != self.segments:
            raise problem(
                f"{self.segments} bending stiffnesses (one per segment)", f"{len(self.bending_stiffness)}"
            )
        return self

    def with_segments(self, n: int) -> "Panel":
        """The same panel cut into ``n`` segments, stiffnesses derived from EI(s) (validated copy).

        Raises
        ------
        ScenarioError
            If ``n`` is not an integer in ``[1, MAX_SEGMENTS]`` (checked before anything is allocated).
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_SEGMENTS:
            raise ScenarioError([Problem(f"{self.name}.segments", f"an integer in [1, {MAX_SEGMENTS}]", repr(n))])
        k = refine_stiffness(self.bending_stiffness, self.length, int(n))
        data = self.model_dump()
        data.update(segments=int(n), bending_stiffness=tuple(float(x) for x in k))
        return Panel.model_validate(data)


class _Body(Frozen):
    """A spacecraft body.

    Attributes
    ----------
    mass : float
        Its mass (kg); with ``properties_include_panels``, the whole spacecraft's.
    inertia : 3x3 list of float
        About its centre of mass, in its body frame (kg m^2).
    panels : list of Panel
        Its flexible panels (``[[chaser.panels]]``, ``[[target.panels]]``).
    properties_include_panels : bool
        True when mass and inertia describe the whole spacecraft with its panels undeformed: the model
        subtracts the panels to get the rigid hub.
    """

    mass: Mass
    inertia: Inertia
    panels: tuple[Panel, ...] = ()
    # True when mass, centre of mass and inertia describe the whole spacecraft with its panels
    # undeformed; the model then subtracts the panels to get the rigid hub.
    properties_include_panels: bool = False

    @field_validator("panels")
    @classmethod
    def _unique(cls, panels):
        names = [p.name for p in panels]
        if len(set(names)) != len(names):
            raise problem("unique panel names", names)
        return panels


class Chaser(_Body):
    """The chaser spacecraft; B is at its centre of mass (with panels if they are included).

    Attributes
    ----------
    accelerometer_position : list of 3 float
        Where the accelerometer sits, in B (m).
    """

    accelerometer_position: Position3 = (0.0, 0.0, 0.0)  # in B (m)


class Target(_Body):
    """The captured target. ``grasp_to_com`` is the pose of T (origin at the CoM) in the grasp frame G.

    Attributes
    ----------
    grasp_to_com : Pose
        T (origin at the target's centre of mass) in the arm's grasp frame G: ``xyz`` (m), ``rpy`` (rad).
    """

    grasp_to_com: Pose = Pose()


class ArmJoint(Frozen):
    """One revolute arm joint, its elastic transmission and the link it carries.

    ``origin`` places the joint frame in the previous link's frame (the arm base for joint 1); the joint
    turns about ``axis`` of its own frame. The joint spring pulls the link angle towards ``rest_angle``
    (the braked or commanded position). With ``rotor_inertia`` the joint follows Spong's flexible-joint
    model: a motor rotor with that (reflected) inertia, held at ``rest_angle`` by a servo of stiffness
    ``servo_stiffness`` and damping ``servo_damping``, drives the link through the joint spring, and the
    motor torque input acts on the rotor.

    Attributes
    ----------
    axis : {"x", "y", "z"}
        The joint's axis in its own frame.
    origin : Pose
        The joint frame in the previous link's frame (the arm base for joint 1).
    mass : float
        The link's mass (kg).
    com : list of 3 float
        The link's centre of mass in the joint frame (m).
    inertia : 3x3 list of float
        The link's inertia about its centre of mass, joint-frame axes (kg m^2).
    stiffness : float
        The joint spring (N m/rad).
    damping : float
        The joint damper (N m s/rad).
    rest_angle : float
        The angle the spring pulls towards (rad).
    rotor_inertia, servo_stiffness, servo_damping : float, optional
        Spong's motor rotor (kg m^2, reflected) and its servo (N m/rad, N m s/rad).
    """

    axis: AxisName
    origin: Pose = Pose()
    mass: Mass
    com: Position3 = (0.0, 0.0, 0.0)
    inertia: Inertia
    stiffness: Stiffness
    damping: Damping = 0.0
    rest_angle: Angle = 0.0
    rotor_inertia: quantity("kg m^2", gt=0.0, le=1.0e6) | None = None
    servo_stiffness: Stiffness | None = None
    servo_damping: Damping | None = None


class Arm(Frozen):
    """The manipulator: base pose in B, joints from base to tool, tool (grasp) frame in the last link.

    Attributes
    ----------
    base : Pose
        The arm base in B.
    joints : list of ArmJoint
        ``[[arm.joints]]``, from base to tool.
    tool : Pose
        The grasp frame G in the last link's frame.
    """

    base: Pose = Pose()
    joints: tuple[ArmJoint, ...] = Field(min_length=1)
    tool: Pose = Pose()


class InitialState(Frozen):
    """Initial state. The stack starts turning as one body at ``omega_BN_B`` about its centre of mass.

    ``elastic = "relaxed"`` starts the joints at the deflection where the elastic coordinates have no
    acceleration at the initial rates (no start-up transient); ``"undeformed"`` at their rest angles.

    Attributes
    ----------
    q_BN : list of 4 float
        Attitude of B relative to N, scalar first (w, x, y, z), unit norm.
    omega_BN_B : list of 3 float
        Angular velocity of the stack, B components (rad/s).
    com_velocity_N : list of 3 float
        Velocity of the stack's centre of mass, N components (m/s).
    elastic : {"relaxed", "undeformed"}
        Where the elastic joints start.
    """

    q_BN: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    omega_BN_B: vector("rad/s", 10.0) = (0.0, 0.0, 0.0)  # rad/s
    com_velocity_N: vector("m/s", 1.0e4) = (0.0, 0.0, 0.0)  # m/s
    elastic: Literal["relaxed", "undeformed"] = "relaxed"

    @field_validator("q_BN")
    @classmethod
    def _unit(cls, q):
        n = float(np.linalg.norm(q))
        if abs(n - 1.0) > 1e-6:
            raise problem("a unit quaternion (w, x, y, z)", f"norm {n:.9g}")
        return q


class Simulation(Frozen):
    """The truth simulation: duration, output sample period and the truth's own integrator and accuracy.

    The truth is the physics: by default its step follows from its declared accuracy
    (:func:`postcapture.dynamics.accuracy.choose_step`), the largest ``sample_period / 2^k`` whose
    estimated error over the run stays within ``tolerance`` on the attitude (rad; 1 arcsec is
    ``4.85e-6``), ``rate_tolerance`` on the body rate averaged over each sample period (rad/s: what a
    rate-integrating gyro reads) and ``joint_tolerance`` on the arm's joint angles (rad: what the
    encoders read). An explicit ``step`` runs the truth at that step instead (the tolerances are then
    not used). The filters' process model has settings of its own (``[estimation] integrator`` and
    ``model_step``): nothing here changes the filters.

    Attributes
    ----------
    duration : float
        Simulated time (s).
    integrator : str
        The truth's integrator.
    step : float, optional
        The truth's step (s), which ``sample_period`` must be a whole multiple of; none (the default):
        chosen from the tolerances.
    sample_period : float
        Output and sensor sample period (s).
    tolerance, rate_tolerance, joint_tolerance : float
        Accuracy of the truth over the run on the attitude (rad), on the body rate averaged over each
        sample period (rad/s) and on the joint angles (rad); see above.
    """

    duration: Duration = 100.0
    integrator: Literal[INTEGRATORS] = "sdirk4"
    step: quantity("s", gt=0.0, le=1.0e3) | None = None
    sample_period: quantity("s", gt=0.0, le=1.0e3) = 0.1
    tolerance: quantity("rad", gt=0.0, le=1.0) = 4.85e-6
    rate_tolerance: quantity("rad/s", gt=0.0, le=1.0) = 5.0e-7
    joint_tolerance: quantity("rad", gt=0.0, le=1.0) = 1.0e-6

    @model_validator(mode="after")
    def _grid(self):
        if not MIN_SAMPLE_PERIOD <= self.sample_period <= self.duration:
            raise problem(f"sample_period between {MIN_SAMPLE_PERIOD:g} s and the duration ({self.duration:g} s)",
                          self.sample_period)
        if self.step is not None:
            ratio = self.sample_period / self.step
            if not np.isfinite(ratio) or abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
                raise problem(f"sample_period a whole multiple of step = {self.step}", self.sample_period)
        return self


EARTH_MU = 3.986004418e14  # m^3/s^2, Earth's gravitational parameter (IERS / WGS 84)
EARTH_RADIUS = 6378137.0  # m, WGS 84 equatorial radius


class Orbit(Frozen):
    """The stack's circular orbit: the truth feels its gravity gradient on every body.

    N is the orbit's local-vertical local-horizontal frame at t = 0 (x the zenith, y along the track, z the
    orbit normal), not rotating, with its origin on the reference orbit: it falls freely, so what acts is the
    tidal field ``n^2 (3 (r . x) r - x)`` (``r`` the zenith at t, ``n`` the mean motion), and the
    accelerometer reads the specific force without it. ``filters = "cover"`` leaves the field out of the
    filters' model, whose derived model error then covers it; ``"model"`` puts it in (their step Jacobians
    leave out its derivatives, about ``3 n^2 dI``: 0.3 N m/rad on Envisat against 1e5 for an arm joint).

    Attributes
    ----------
    altitude : float
        Height of the circular orbit above the equatorial radius (m).
    filters : str
        ``"cover"`` or ``"model"`` (see above).
    """

    altitude: quantity("m", gt=1.0e5, le=1.0e8) = 7.7e5
    filters: Literal["cover", "model"] = "cover"

    @property
    def mean_motion(self) -> float:
        """``sqrt(mu / a^3)`` (rad/s)."""
        return float(np.sqrt(EARTH_MU / (EARTH_RADIUS + self.altitude) ** 3))


def orbit_mean_motion(scenario, side: str) -> float:
    """The mean motion of the gravity gradient ``side`` (``"truth"`` or ``"filters"``) feels (0: free space)."""
    orbit = scenario.orbit
    if orbit is None or (side == "filters" and orbit.filters == "cover"):
        return 0.0
    return orbit.mean_motion


def fault_problems(faults, duration: float) -> list[tuple[str, str, str]]:
    """``(path, expected, found)`` of every fault whose window does not lie inside a run of ``duration`` s."""
    out = []
    for i, fault in enumerate(faults):
        start, stop = fault_window(fault)
        if start >= duration:
            out.append((f"faults[{i}]", f"a fault starting inside the run (before {duration:g} s)", f"{start:g} s"))
        elif stop is not None and stop > duration:
            out.append((f"faults[{i}].stop", f"a fault window ending inside the run (at most {duration:g} s)",
                        f"{stop:g} s"))
    return out


class Scenario(Frozen):
    """A complete post-capture scenario.

    Attributes
    ----------
    name : str
        Names the scenario in titles and file names.
    description : str
        Free text.
    chaser : Chaser
        ``[chaser]``.
    arm : Arm, optional
        ``[arm]``; required with a target.
    target : Target, optional
        ``[target]``.
    excitation : list
        ``[[excitation]]``: known inputs (thrusters, joint torques) by ``kind``.
    initial : InitialState
        ``[initial]``.
    simulation : Simulation
        ``[simulation]``.
    estimation : Estimation
        ``[estimation]``: the filters' settings, sensor overrides and tunings per profile.
    uncertainty : Uncertainty
        ``[uncertainty]``: what the filters do not know (priors).
    faults : list
        ``[[faults]]``: scheduled sensor faults by ``kind``.
    orbit : Orbit
        ``[orbit]``: the circular orbit whose gravity gradient the truth feels; none: free space.
    """

    name: Name
    description: Text = ""
    chaser: Chaser
    arm: Arm | None = None
    target: Target | None = None
    excitation: tuple[Excitation, ...] = ()
    initial: InitialState = InitialState()
    simulation: Simulation = Simulation()
    estimation: Estimation = Estimation()
    uncertainty: Uncertainty = Uncertainty()
    faults: tuple[Fault, ...] = ()
    orbit: Orbit | None = None

    @model_validator(mode="after")
    def _consistency(self):
        found = []  # (path, expected, found): every cross-section problem, reported together
        if self.target is not None and self.arm is None:
            found.append(("target", "an arm to hold the target", "a target without an arm"))
        n_arm = len(self.arm.joints) if self.arm is not None else 0
        for section in ("sensors", "tuning"):
            unknown = sorted(set(getattr(self.estimation, section)) - set(PROFILES))
            if unknown:
                found.append((f"estimation.{section}", f"profiles among {', '.join(PROFILES)}", unknown))
        for i, fault in enumerate(self.faults):
            if isinstance(fault, JointFault) and fault.joint > n_arm:
                found.append((f"faults[{i}].joint", f"a joint among the arm's joints 1..{n_arm}", fault.joint))
        found += fault_problems(self.faults, self.simulation.duration)
        unc = self.uncertainty
        if unc.target_mass is not None and self.target is not None:
            lowest = self.target.mass + unc.target_mass.extremes()[0]
            panels = sum(p.mass for p in self.target.panels)
            if lowest <= panels:
                found.append(("uncertainty.target_mass", f"draws that keep the target heavier than its panels "
                                                         f"({panels:g} kg)", f"draws down to {lowest:g} kg"))
        for i, ex in enumerate(self.excitation):
            try:
                channel_index(ex.channel, n_arm)
            except ValueError:
                found.append((f"excitation[{i}].channel", f"a channel on an existing input (the arm has {n_arm} "
                                                          "joints)", repr(ex.channel)))
        if found:
            raise problems(found)
        return self

    def __repr__(self) -> str:
        target = f"target {self.target.mass:g} kg" if self.target is not None else "no target"
        return (f"Scenario({self.name!r}: chaser {self.chaser.mass:g} kg, {self.n_arm} arm joints, {target}, "
                f"{len(self.panels())} panels, {self.simulation.duration:g} s)")

    @property
    def n_arm(self) -> int:
        """Number of arm joints."""
        return len(self.arm.joints) if self.arm is not None else 0

    @property
    def n_inputs(self) -> int:
        """Length of the input vector ``u = [F_B, tau_B, tau_arm]``."""
        return 6 + self.n_arm

    def panels(self) -> list[tuple[str, Panel]]:
        """Every panel with its host body ("chaser" or "target")."""
        out = [("chaser", p) for p in self.chaser.panels]
        if self.target is not None:
            out += [("target", p) for p in self.target.panels]
        return out

    def with_panel_segments(self, n: int) -> "Scenario":
        """The same scenario with every panel cut into ``n`` segments (a validated copy).

        Raises
        ------
        ScenarioError
            If ``n`` is not an integer in ``[1, MAX_SEGMENTS]``.
        """
        data = self.model_dump()
        data["chaser"]["panels"] = tuple(p.with_segments(n).model_dump() for p in self.chaser.panels)
        if self.target is not None:
            data["target"]["panels"] = tuple(p.with_segments(n).model_dump() for p in self.target.panels)
        return Scenario.model_validate(data)

    def with_updates(self, **sections) -> "Scenario":
        """A validated copy with whole sections replaced, e.g. ``simulation=...``."""
        data = self.model_dump()
        for key, value in sections.items():
            data[key] = value.model_dump() if hasattr(value, "model_dump") else value
        return Scenario.model_validate(data)
