"""Workflow YAML schema (pydantic): one machine and what to compute with it.

The reference with an annotated example is ``docs/workflows.md``. Fields are SI
(m, kg, s, N, rad). Unknown keys are rejected; cross-references (link.frame,
coordinates, analyses named by plots) are checked after the machine is built,
where the coordinate names are known.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import AfterValidator, Field, field_validator, model_validator

from pipeline.post.units import ANGLE, FORCE, LENGTH, STRESS
from pipeline.post.views import check_camera
from pipeline.workflow.link_spec import MAX_COORDINATE, LinkSpec, Mat3, Pos3, Strict, Vec3

Name = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$")]
Inertia = Annotated[list[float], Field(min_length=6, max_length=6)] | Mat3


#: fields of force elements that name a marker as "link.frame"
MARKER_FIELDS = ("marker", "marker_a", "marker_b")


class FrameSpec(Strict):
    """A frame fixed to a link: origin (m) and axes in the link's coordinates."""

    origin: Pos3 = Field([0.0, 0.0, 0.0], description="m, link coordinates")
    z: Vec3 | None = Field(None, description="direction of the frame's z axis (joint axis)")
    x: Vec3 | None = Field(None, description="direction of the frame's x axis (made normal to z)")
    on: str | None = Field(None, description="flexible links: spec interface/marker the frame is "
                                             "fixed to (origin and axes in that frame's axes)")


class BoxShape(Strict):
    type: Literal["box"]
    size: Pos3 = Field(description="edge lengths, m")
    center: Pos3 = Field([0.0, 0.0, 0.0], description="m, link coordinates")


class CylinderShape(Strict):
    type: Literal["cylinder"]
    start: Pos3 = Field(alias="from", description="axis start, m")
    end: Pos3 = Field(alias="to", description="axis end, m")
    radius: float = Field(gt=0, description="m")


class SticksShape(Strict):
    type: Literal["sticks"]
    radius: float = Field(0.02, gt=0, description="tube radius between the frames, m")


Shape = Annotated[BoxShape | CylinderShape | SticksShape, Field(discriminator="type")]


class GroundLink(Strict):
    type: Literal["ground"]
    frames: dict[Name, FrameSpec] = Field(default_factory=dict)
    shape: Shape | None = None


class RigidLink(Strict):
    """Rigid link: mass properties given, computed from a meshed ``spec``, or neither (a
    massless intermediate link, e.g. between the joints of a heave-pitch-roll chain)."""

    type: Literal["rigid"]
    mass: float | None = Field(None, gt=0, description="kg")
    com: Pos3 | None = Field(None, description="centre of mass, m, link coordinates")
    inertia: Inertia | None = Field(
        None, description="about the COM in link axes, kg m^2: [ixx, iyy, izz, ixy, iyz, ixz] "
                          "or a 3x3 matrix")
    spec: str | LinkSpec | None = Field(
        None, description="link spec (file relative to the workflow, or inline): mass "
                          "properties and picture from its mesh")
    spec_overrides: dict[str, Any] = Field(
        default_factory=dict, description="dotted overrides of the link spec, e.g. "
                                          "{geometry.mesh_size: 0.02}")
    frames: dict[Name, FrameSpec] = Field(default_factory=dict)
    shape: Shape | None = None

    @model_validator(mode="after")
    def _mass_source(self):
        given = self.mass is not None
        if given and self.spec is not None:
            raise ValueError("give either mass (with com, inertia) or spec, not both")
        if given and self.inertia is None:
            raise ValueError("a rigid link with mass needs inertia (kg m^2 about the COM)")
        if not given and (self.com is not None or self.inertia is not None):
            raise ValueError("com and inertia need mass")
        if self.inertia is not None:
            check_inertia(inertia_matrix(self.inertia))
        return self


def inertia_matrix(value) -> np.ndarray:
    """(3, 3) inertia tensor, kg m^2, from [ixx, iyy, izz, ixy, iyz, ixz] or a 3x3 list."""
    a = np.asarray(value, dtype=float)
    if a.shape == (6,):
        ixx, iyy, izz, ixy, iyz, ixz = a
        a = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    return a


def principal_moments(J: np.ndarray) -> np.ndarray:
    """(3,) ascending eigenvalues of the symmetric J (3, 3), kg m^2, scaled by its largest
    entry first (entries near 1e308 overflowed numpy's solver: a RuntimeWarning and NaN)."""
    scale = float(np.abs(J).max())
    return np.linalg.eigvalsh(J / scale) * scale if scale > 0 else np.zeros(3)


def _listed(moments: np.ndarray) -> list[float]:
    # rounded to 1e-12 of the largest (round-off zeros read 0), without np.round's
    # scaling, which overflows near 1e308
    scale = float(np.abs(moments).max()) or 1.0
    return [float(f"{round(m / scale, 12) * scale:.10g}") + 0.0 for m in moments]


def check_inertia(J: np.ndarray) -> None:
    """ValueError unless J (3, 3) can be an inertia tensor about the COM for some motion:
    finite, symmetric, no negative principal moment. A zero moment (a thin rod about its
    axis) and moments that break the triangle inequality (a flywheel's reflected drivetrain
    inertia about one axis) are modelling idioms, accepted: whether the machine has inertia
    for every motion its joints allow is checked when it is built
    (:func:`pipeline.dynamics.inertia_check.motion_without_inertia`)."""
    if not np.all(np.isfinite(J)):
        raise ValueError(f"inertia has values that are not finite: {J.tolist()}")
    scale = float(np.abs(J).max())
    if np.abs(J - J.T).max() > 1e-9 * scale:
        raise ValueError(f"inertia is not symmetric: {J.tolist()}")
    moments = principal_moments(J)
    if moments[0] < -1e-12 * scale:
        raise ValueError(f"inertia has a negative principal moment: "
                         f"{_listed(moments)} kg m^2 (a sign or a product of "
                         "inertia mixed up?)")


def inertia_note(J: np.ndarray) -> str | None:
    """What an accepted inertia (:func:`check_inertia`) is not, as one clause, or None: no
    moment about an axis, or principal moments no single rigid body has."""
    scale = float(np.abs(J).max())
    moments = principal_moments(J)
    if scale == 0.0 or moments[0] <= 1e-12 * scale:
        return (f"principal moments {_listed(moments)} kg m^2 give it no inertia "
                "about an axis (a thin rod, a point mass)")
    if moments[0] + moments[1] < moments[2] * (1.0 - 1e-9):
        return (f"principal moments {_listed(moments)} kg m^2 break the triangle "
                "inequality I1 + I2 >= I3: no single rigid body has them (a reflected "
                "drivetrain inertia about one axis)")
    return None


class DampingSpec(Strict):
    ratio: float | None = Field(None, ge=0, description="modal damping ratio of every kept mode")
    ratios: list[Annotated[float, Field(ge=0)]] | None = Field(
        None, description="damping ratio per kept mode, by frequency")
    rayleigh: Annotated[list[float], Field(min_length=2, max_length=2)] | None = Field(
        None, description="[alpha (1/s), beta (s)]: D = alpha M + beta K")

    @model_validator(mode="after")
    def _one(self):
        if sum(v is not None for v in (self.ratio, self.ratios, self.rayleigh)) != 1:
            raise ValueError("give exactly one of ratio, ratios, rayleigh")
        return self


class ModeSelection(Strict):
    """Modes kept by rule, among the modes the spec computes (in the plane, if given):
    those up to ``f_max``, then the lowest ones whose effective masses reach
    ``effective_mass`` of the link's mass (translations) and inertia (rotations) in each
    of ``directions`` at ``interface``; ``count`` caps the number."""

    f_max: float | None = Field(None, gt=0, description="Hz")
    effective_mass: float | None = Field(None, gt=0, le=1, description="fraction, e.g. 0.9")
    directions: list[Literal["tx", "ty", "tz", "rx", "ry", "rz"]] | None = Field(
        None, description="default: every direction the computed modes can reach")
    interface: str | None = Field(None, description="default: the reference interface")
    count: int | None = Field(None, ge=0, description="at most this many")

    @model_validator(mode="after")
    def _a_rule(self):
        if self.f_max is None and self.effective_mass is None and self.count is None:
            raise ValueError("give f_max, effective_mass or count")
        return self


class FlexibleLink(Strict):
    """Flexible link reduced from a link spec (gmsh + scikit-fem), modes clamped at its
    reference interface (the body frame)."""

    type: Literal["flexible"]
    spec: str | LinkSpec = Field(description="link spec file (relative to the workflow) or "
                                             "inline, or a reduced link file (.h5, "
                                             "docs/hdf5_format.md) used as it is")
    spec_overrides: dict[str, Any] = Field(
        default_factory=dict, description="dotted overrides of the link spec, e.g. "
                                          "{geometry.mesh_size: 0.02, modes.count: 4}")
    modes: Annotated[int, Field(ge=0)] | list[Annotated[int, Field(ge=0)]] | ModeSelection \
        | None = Field(
        None, description="kept modes: a count (the lowest n), 0-based indices, or a rule "
                          "{f_max, effective_mass, directions, interface, count}; "
                          "default all the spec computes; 0 makes the link rigid")
    plane: Literal["xy", "yz", "xz"] | None = Field(
        None, description="keep only modes moving in this plane of the body frame")
    damping: DampingSpec | None = None
    geometric_stiffening: bool = Field(
        False, description="geometric stiffening of the modes by the forces at the link's "
                           "frames, its own acceleration, gravity and its own spin: "
                           "computed with the reduction, applied in every analysis")
    frames: dict[Name, FrameSpec] = Field(
        default_factory=dict, description="extra frames, each fixed `on` a spec frame")

    @field_validator("frames")
    @classmethod
    def _frames_on(cls, value: dict[str, FrameSpec]) -> dict[str, FrameSpec]:
        missing = [k for k, f in value.items() if f.on is None]
        if missing:
            raise ValueError(f"frames {missing}: a flexible link's extra frame needs `on:` "
                             "(the spec interface or marker it is fixed to)")
        return value


LinkEntry = Annotated[GroundLink | RigidLink | FlexibleLink, Field(discriminator="type")]


#: a joint coordinate's value or rate (rad, m; /s): within +-MAX_COORDINATE (1e308 overflowed
#: the assembly's least squares)
Coordinate = Annotated[float, Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]


class JointSpec(Strict):
    name: Name
    type: str = Field(description="revolute | prismatic | cylindrical | universal | spherical | "
                                  "planar | fixed | free")
    parent: str = Field(description="link.frame of the parent side")
    child: str = Field(description="link.frame of the child side")
    initial: list[Coordinate] = Field(default_factory=list,
                                      description="approximate assembly values, rad / m")

    @field_validator("parent", "child")
    @classmethod
    def _dotted(cls, value: str) -> str:
        if value.count(".") < 1 or value.startswith(".") or value.endswith("."):
            raise ValueError(f"expected 'link.frame', got {value!r}")
        return value


class ForceSpec(Strict, extra="allow"):
    """A force element; extra keys are the element's fields (pipeline.dynamics.FORCES)."""

    name: Name
    type: str


class InitialSpec(Strict):
    coordinates: dict[str, Coordinate] = Field(default_factory=dict, description="rad / m")
    velocities: dict[str, Coordinate] = Field(default_factory=dict, description="rad/s, m/s")


class CaseSpec(Strict):
    label: str
    set: dict[str, Any] = Field(default_factory=dict,
                                description="overrides (dotted paths, as --set)")
    expect: Literal["ok", "suspect"] = Field(
        "ok", description="the verdict this case is meant to end with: 'suspect' for a "
        "comparison case kept to show what a model leaves out (it still reports its "
        "warnings; the workflow is suspect only if the case ends otherwise)")


class _Analysis(Strict):
    name: Name
    initial: InitialSpec | None = Field(
        None, description="this analysis' start (replaces the workflow's initial:)")
    cases: list[CaseSpec] = Field(default_factory=list)
    markers: list[str] = Field(default_factory=list, description="link.frame histories to record")

    @field_validator("cases")
    @classmethod
    def _labels(cls, value: list[CaseSpec]) -> list[CaseSpec]:
        labels = [c.label for c in value]
        dup = sorted({x for x in labels if labels.count(x) > 1})
        if dup:
            raise ValueError(f"duplicate case labels {dup}")
        return value


#: most output times of one analysis (each holds the whole state: 1e6 x 100 coordinates
#: is already ~2 GB of histories)
MAX_OUTPUTS = 1_000_000


class _Timed(_Analysis):
    t_end: float = Field(gt=0, description="s")
    outputs: int = Field(101, ge=2, le=MAX_OUTPUTS, description="number of output times on "
                                                                 "[0, t_end]")


class KinematicAnalysis(_Timed):
    type: Literal["kinematic"]


class StaticAnalysis(_Analysis):
    type: Literal["static"]
    t: float = Field(0.0, description="time at which the drivers are evaluated, s")
    hold: list[str] = Field(default_factory=list, description="coordinates held fixed")
    trapped: bool = Field(False, description="hydraulic oil trapped behind closed valves: "
                                             "the chamber pressures start at their start "
                                             "values and follow the stroke (the statics "
                                             "finds where the compressed oil holds the "
                                             "load)")


class KinetostaticAnalysis(_Timed):
    type: Literal["kinetostatic"]
    inertia: bool = Field(False, description="include inertia forces")
    reactions: bool = Field(False, description="joint reactions at every output")
    hold: list[str] | None = Field(None, description="held coordinates (default: every free "
                                                     "joint coordinate)")


class ChecksSpec(Strict):
    """Thresholds of the trust checks on a dynamic run (a run beyond one is "suspect")."""

    energy: float = Field(1e-2, gt=0, description="largest change of the energy balance, "
                                                  "relative to the energy the run exchanged")
    closure: float = Field(1e-6, gt=0, description="largest loop-closure residual, m or rad")
    deformation: float = Field(0.10, gt=0, description="largest elastic displacement of a "
                                                       "flexible link relative to its size")
    rotation: float = Field(0.15, gt=0, description="largest elastic frame rotation, rad")
    min_step: float = Field(1e-9, gt=0, description="smallest step relative to the span")
    spin: float = Field(0.05, gt=0, description="largest Omega^2 / omega_1^2 of a flexible "
                                                "link without geometric stiffening")
    axial: float = Field(0.05, gt=0, description="largest axial force / Euler load of a "
                                                 "flexible link without geometric stiffening")


class StaticStart(Strict):
    """A dynamic run's start from static equilibrium, optionally under loads released at
    t = 0 (a pluck test): the start is the equilibrium with every force element, the run
    goes on without the ``loads`` ones."""

    hold: list[str] = Field(default_factory=list, description="coordinates held at their "
                                                              "initial values in the start")
    loads: list[str] = Field(default_factory=list, description="force elements applied only "
                                                               "to find the start (released "
                                                               "at t = 0)")

    @field_validator("loads")
    @classmethod
    def _unique(cls, value: list[str]) -> list[str]:
        dup = sorted({x for x in value if value.count(x) > 1})
        if dup:
            raise ValueError(f"force elements listed twice: {dup}")
        return value


class FmuSpec(Strict):
    """An FMU (FMI 2 or 3, co-simulation or model exchange) beside the machine
    (pipeline.solver.cosim)."""

    path: str = Field(description="the .fmu file, relative to the workflow's folder")
    name: str | None = Field(None, description="by which other blocks read its outputs "
                                               "(block:<name>.<output>)")
    inputs: dict[str, str] = Field(default_factory=dict, description="FMU input variable: "
                                   "the machine's signal (q:<coordinate>, qd:<coordinate>, "
                                   "state:<element>.<state>, marker:<link>.<frame>:x|y|z, "
                                   "time) or another block's output "
                                   "(block:<name>.<output>)")
    outputs: dict[str, str] = Field(default_factory=dict, description="FMU output variable: "
                                    "the force element or driven coordinate it drives")
    parameters: dict[str, float | bool | str] = Field(
        default_factory=dict, description="start values: numbers, or text for a String "
                                          "variable")


class ControllerSpec(Strict):
    """A digital PID controller beside the machine, sampled every ``period`` with its output
    held (pipeline.solver.cosim.SampledPID)."""

    type: Literal["pid"] = "pid"
    name: str | None = Field(None, description="by which other blocks read its output "
                                               "(block:<name>.output)")
    measured: str = Field(description="the machine's signal (q:<coordinate>, "
                                      "qd:<coordinate>, state:<element>.<state>, "
                                      "marker:<link>.<frame>:x|y|z, time) or another "
                                      "block's output (block:<name>.<output>)")
    output: str = Field(description="the force element it drives (its history; a "
                                    "cylinder's valve command) or a driven coordinate")
    reference: float | dict[str, Any] = Field(description="r(t): a number or a driver")
    kp: float = Field(ge=0, description="output per unit of the measured signal")
    ki: float = Field(0.0, ge=0, description="per unit and second")
    kd: float = Field(0.0, ge=0, description="per unit per second, on the measurement")
    period: float = Field(gt=0, description="sampling period, s")
    output_limits: tuple[float, float] | None = Field(None, description="[u_min, u_max]")
    tracking_time: float | None = Field(None, gt=0, description="anti-windup, s (default "
                                                                 "sqrt(T_i T_d))")
    feedforward: float = Field(0.0, ge=0, description="output per unit/s of the "
                                                      "reference's rate")


class DynamicAnalysis(_Timed):
    type: Literal["dynamic"]
    fmus: list[FmuSpec] = Field(default_factory=list, description="FMUs co-simulated with "
                                "the machine (generalized_alpha with a fixed step; the "
                                "outputs are the communication points)")
    controllers: list[ControllerSpec] = Field(
        default_factory=list, description="digital controllers beside the machine "
                                          "(generalized_alpha with a fixed step; the outputs "
                                          "are the communication points)")
    macro_step: float | None = Field(None, gt=0, description="the communication step of the "
                                                             "FMUs and controllers, s "
                                                             "(default without FMUs: the "
                                                             "shortest controller period)")
    coupling_error: bool = Field(True, description="estimate the co-simulation's coupling "
                                                   "error (the blocks again at half the "
                                                   "macro step); false where an FMU is a "
                                                   "digital controller sampled at the macro "
                                                   "step by design")
    method: str = Field("DOP853", description="DOP853 | Radau | BDF | RK45 | LSODA | "
                                              "generalized_alpha")
    formulation: Literal["auto", "dae", "partitioned"] = Field(
        "auto", description="closed loops: dae (every coordinate with multipliers; default) "
                            "or partitioned (independent coordinates, the seed's method)")
    max_steps: int = Field(1_000_000, ge=1, description="step budget")
    max_wall: float | None = Field(3600.0, gt=0, description="wall-clock budget, s (null: "
                                                             "none)")
    checks: ChecksSpec = Field(default_factory=ChecksSpec)
    rtol: float = Field(1e-8, gt=0)
    atol: float = Field(1e-10, gt=0)
    max_step: float | None = Field(None, gt=0, description="s")
    step: float | None = Field(None, gt=0, description="fixed step (generalized_alpha; "
                                                       "adaptive when absent in the DAE), s")
    rho_inf: float = Field(0.8, ge=0, le=1, description="generalized_alpha spectral radius")
    start: Literal["initial", "static"] | StaticStart = Field(
        "initial", description="start from the initial state, from static equilibrium, or "
                               "{hold: [...], loads: [...]}: static equilibrium with coordinates "
                               "held and loads released at t = 0")

    @model_validator(mode="after")
    def _cosimulation(self):
        if self.fmus and (self.method != "generalized_alpha" or self.step is None
                          or self.macro_step is None):
            raise ValueError("fmus: a co-simulation runs method generalized_alpha with a "
                             "fixed step and a macro_step (the FMUs' communication step)")
        if self.controllers and (self.method != "generalized_alpha" or self.step is None):
            raise ValueError("controllers: a digital controller runs beside method "
                             "generalized_alpha with a fixed step")
        return self

    @model_validator(mode="after")
    def _within_budget(self):
        """A fixed step, or a largest step, that needs more steps than the budget allows
        is refused here rather than found out after max_steps steps."""
        for key in ("step", "max_step"):
            h = getattr(self, key)
            if h is not None and self.t_end / h > self.max_steps:
                raise ValueError(f"{key}: {h:g} s needs at least {self.t_end / h:.3g} steps over "
                                 f"t_end = {self.t_end:g} s, more than max_steps = "
                                 f"{self.max_steps}; raise the step or max_steps")
        return self


class LinearisedAnalysis(_Analysis):
    type: Literal["linearised"]
    start: Literal["initial", "static"] = Field("static")
    t: float = Field(0.0, description="time at which the drivers are evaluated, s")
    count: int = Field(10, ge=1, description="number of lowest modes reported")
    hold: list[str] = Field(default_factory=list, description="coordinates held fixed")


Analysis = Annotated[
    KinematicAnalysis | StaticAnalysis | KinetostaticAnalysis | DynamicAnalysis
    | LinearisedAnalysis, Field(discriminator="type")]


class UnitsSpec(Strict):
    """Units plots are drawn in (exports stay SI)."""

    length: Literal[tuple(LENGTH)] = "m"
    force: Literal[tuple(FORCE)] = "N"
    angle: Literal[tuple(ANGLE)] = "rad"
    stress: Literal[tuple(STRESS)] = "MPa"


class PlotSpec(Strict):
    name: Name
    analysis: str
    series: list[str] = Field(min_length=1, description="kind:target[:component] histories")
    x: str = Field("time", description="time or a series")
    title: str | None = None
    ylabel: str | None = None
    cases: list[str] | None = Field(None, description="case labels to draw (default all)")
    units: UnitsSpec | None = Field(None, description="this plot's units (default outputs.units)")


Scale = Annotated[float, Field(gt=0)] | Literal["auto"]
Camera = Annotated[Literal["xy", "xz", "yz", "iso"] | Vec3, AfterValidator(check_camera)]


class RenderSpec(Strict):
    name: Name
    analysis: str
    scale: Scale = Field("auto", description="elastic magnification")
    camera: Camera = Field(
        "iso", description="named view or a view direction [x, y, z] (scene -> camera)")
    at: list[float] | None = Field(None, description="output times (s) to show; default: "
                                                     "the last (timed) or every case (static)")
    case: str | None = Field(None, description="case label (default the first)")
    title: str | None = Field(None, description="'{scale}' in it is replaced by the "
                                                "magnification drawn (as --set may change it)")
    color: Literal["displacement", "von_mises"] = Field(
        "displacement", description="colour flexible links by elastic displacement (mm) or "
                                    "von Mises stress (MPa, solid links)")
    links: list[Name] | None = Field(None, description="draw only these links (default "
                                                       "all): a part on its own")


class AnimationSpec(Strict):
    name: Name
    analysis: str
    scale: Scale = "auto"
    camera: Camera = "iso"
    format: Literal["gif", "mp4"] = "gif"
    case: str | None = None
    fps: int = Field(15, ge=1, le=60)
    max_frames: int = Field(60, ge=2, le=600)
    color: Literal["displacement", "von_mises"] = "displacement"
    links: list[Name] | None = None


class ConvergenceSpec(Strict):
    """Mode-truncation (or any case) study: how far each case is from a reference case."""

    name: Name
    analysis: str
    series: list[str] = Field(min_length=1, description="histories compared")
    reference: str | None = Field(None, description="reference case label (default the last)")
    title: str | None = None


class ExportSpec(Strict):
    csv: bool = True
    npz: bool = True
    store: bool = Field(True, description="results.parquet: every series of the run with its "
                                          "unit, and the manifest (needs pyarrow)")
    vtu: bool = Field(False, description="ParaView time series (vtk/<analysis>/*.pvd)")
    vtu_frames: int = Field(100, ge=1, le=5000, description="VTU frames per result at most "
                                                            "(evenly thinned output times)")
    vtu_mb: float | None = Field(40.0, gt=0, description="size budget of all VTU series of a "
                                                         "run, MB: frames are thinned further "
                                                         "to stay within it (null: none)")


class HistorySpec(Strict):
    runs: int = Field(5, ge=0, le=1000, description="earlier runs kept in "
                                                    "output/<name>.history/ (0: none)")
    mb: float | None = Field(500.0, gt=0, description="size budget of the kept runs, MB: "
                                                      "the oldest go first (null: none)")


class OutputSpec(Strict):
    plots: list[PlotSpec] = Field(default_factory=list)
    renders: list[RenderSpec] = Field(default_factory=list)
    animations: list[AnimationSpec] = Field(default_factory=list)
    convergence: list[ConvergenceSpec] = Field(default_factory=list)
    exports: ExportSpec = Field(default_factory=ExportSpec)
    units: UnitsSpec = Field(default_factory=UnitsSpec, description="units of every plot")
    history: HistorySpec = Field(default_factory=HistorySpec,
                                 description="earlier runs kept beside the latest")


class WorkflowSpec(Strict):
    name: Name | None = Field(None, description="output folder name (default: the file stem)")
    description: str = ""
    gravity: Vec3 = Field([0.0, 0.0, -9.81], description="m/s^2, ground axes")
    links: dict[Name, LinkEntry] = Field(min_length=2)
    joints: list[JointSpec] = Field(min_length=1)
    drivers: dict[str, dict[str, Any]] = Field(
        default_factory=dict, description="coordinate -> driver mapping (see docs/workflows.md)")
    forces: list[ForceSpec] = Field(default_factory=list)
    initial: InitialSpec = Field(default_factory=InitialSpec)
    analyses: list[Analysis] = Field(min_length=1)
    outputs: OutputSpec = Field(default_factory=OutputSpec)
    quick: dict[str, Any] = Field(default_factory=dict,
                                  description="overrides applied by --quick (as --set)")

    @property
    def ground(self) -> str:
        return next(k for k, v in self.links.items() if v.type == "ground")

    def analysis(self, name: str):
        return next(a for a in self.analyses if a.name == name)
