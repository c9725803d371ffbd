"""Run one analysis of a workflow on a built machine -> :class:`AnalysisResult`.

Every analysis type produces the same shape of result (times, coordinates,
rates, accelerations, actuator forces, extra arrays), so series, plots and
exports treat them alike. A failure inside an analysis (integration stopped,
equilibrium not found, loops not closable along a sweep) is a status on the
result with the history up to that point, never an exception that loses it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.dynamics import kinetostatics, static_equilibrium, vibration_modes
from pipeline.kinematics import sweep
from pipeline.workflow.build import Machine
from pipeline.workflow.schema import StaticStart


@dataclass(frozen=True)
class AnalysisResult:
    """Histories of one analysis (one case).

    Attributes
    ----------
    name, type, case : analysis name, type and case label ("" without cases).
    success, message : status (partial histories when False).
    verdict : "ok", "suspect" (finished, but a trust check tripped: ``warnings`` says which,
        when and by how much) or "partial" (stopped early: ``message``).
    coordinates : (n,) coordinate names.
    t : (T,) s (static and linearised: one entry, the evaluation time).
    q, qd, qdd : (T, n) coordinates, rates, accelerations (rad, m, /s, /s^2).
    forces : name -> (T,) actuator (driver/held coordinate) force, N or N m.
    energies : name -> (T,) J (dynamic runs).
    extra : further arrays (closure_residual, frequencies_hz, damping_ratios, M, K, C, ...).
    states : {"<element>.<state>": (unit, (T,) values)} of the force elements' own states
        (a hydraulic cylinder's pressures; dynamic analyses).
    timings : seconds ("total").
    """

    name: str
    type: str
    case: str
    success: bool
    message: str
    coordinates: tuple[str, ...]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    forces: dict = field(default_factory=dict)
    energies: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    states: dict = field(default_factory=dict)
    verdict: str = ""
    warnings: tuple = ()

    def __post_init__(self):
        if not self.verdict:
            object.__setattr__(self, "verdict", "ok" if self.success else "partial")

    @property
    def label(self) -> str:
        return self.case or self.name

    @property
    def has_data(self) -> bool:
        """Whether it holds the histories its outputs are drawn from (a failed analysis
        may hold none, or a partial history)."""
        if len(self.t) == 0:
            return False
        return self.type != "linearised" or "frequencies_hz" in self.extra


def _times(a) -> np.ndarray:
    return np.linspace(0.0, a.t_end, a.outputs)


def _hold(m: Machine, names, *path) -> tuple[str, ...]:
    for i, name in enumerate(names):
        if name not in m.mechanism.coordinates:
            raise m.workflow.error(*path, i, msg=f"coordinate {name!r} does not exist; "
                                                 f"coordinates: {list(m.mechanism.coordinates)}")
    return tuple(names)


def _markers(m: Machine, a, path) -> list[tuple[str, str]]:
    out = []
    for i, s in enumerate(a.markers):
        link, _, frame = s.partition(".")
        mech = m.mechanism
        if link not in mech.link_names or frame not in [
                f.name for f in mech.links[mech.link_index(link)].frames]:
            raise m.workflow.error(*path, "markers", i, msg=f"expected an existing link.frame, "
                                                            f"got {s!r}")
        out.append((link, frame))
    return out


def run_kinematic(m: Machine, a, path) -> dict:
    t = _times(a)
    r = sweep(m.mechanism, m.system.drivers, t, m.q0, _markers(m, a, path))
    n = r.n_done
    return {
        "success": r.success,
        "message": r.message,
        "t": t[:n],
        "q": r.q[:n],
        "qd": r.qd[:n],
        "qdd": r.qdd[:n],
        "extra": {"newton_iterations": r.newton_iterations[:n]},
    }


def run_static(m: Machine, a, path) -> dict:
    hold = _hold(m, a.hold, *path, "hold")
    if a.trapped and m.system.state_slices:  # the oil behind closed valves
        try:
            r = static_equilibrium(m.system, m.q0, t=a.t, hold=hold,
                                   z=_start_states(m, a.t), trapped=True)
        except ConfigError as exc:
            raise m.workflow.error(*path, "trapped", msg=str(exc)) from None
    else:
        r = static_equilibrium(m.system, m.q0, t=a.t, hold=hold)
    z = np.zeros((1, m.mechanism.n))
    states = {} if r.z is None else state_histories(m.system, r.z[None, :])
    return {
        "success": r.success,
        "message": r.message,
        "t": np.array([a.t]),
        "q": r.q[None, :],
        "qd": z,
        "qdd": z.copy(),
        "extra": {
            "residual": r.residual,
            "iterations": r.iterations,
            "unknowns": np.array(r.coordinates, dtype=object),
        },
        **({"states": states} if states else {}),
    }


def run_kinetostatic(m: Machine, a, path) -> dict:
    hold = None if a.hold is None else _hold(m, a.hold, *path, "hold")
    r = kinetostatics(m.system, _times(a), m.q0, inertia=a.inertia, hold=hold,
                      reactions=a.reactions)
    n = int(np.sum(np.all(np.isfinite(r.q), axis=1)))
    forces = {name: r.forces[:n, i] for i, name in enumerate(r.names)}
    extra = {}
    if a.reactions and r.reactions:
        extra["reactions"] = r.reactions
    return {
        "success": r.success,
        "message": r.message,
        "t": r.t[:n],
        "q": r.q[:n],
        "qd": r.qd[:n],
        "qdd": r.qdd[:n],
        "forces": forces,
        "extra": extra,
    }


def run_dynamic(m: Machine, a, path) -> dict:
    from pipeline.solver import Limits, simulate

    q0, system = m.q0, m.system
    if a.start != "initial":
        start = StaticStart() if a.start == "static" else a.start
        system = _released(m, start.loads, (*path, "start", "loads"))
        # the states held at their start values deflect the flexible links; the run finds
        # them again at the start
        r = static_equilibrium(m.system, m.q0,
                               hold=_hold(m, start.hold, *path, "start", "hold"),
                               z=_start_states(m, 0.0))
        if not r.success:
            return {
                "success": False,
                "message": f"static start: {r.message}",
                "t": np.zeros(0),
                "q": np.zeros((0, m.mechanism.n)),
                "qd": np.zeros((0, m.mechanism.n)),
                "qdd": np.zeros((0, m.mechanism.n)),
            }
        q0 = r.q
    opts: dict[str, Any] = {}
    if a.max_step is not None:
        opts["max_step"] = a.max_step
    if a.method == "generalized_alpha":
        opts.update(step=a.step, rho_inf=a.rho_inf)
    elif a.step is not None:
        raise m.workflow.error(*path, "step", msg="a fixed step is for method "
                                                  "generalized_alpha; use max_step otherwise")
    c = a.checks
    limits = Limits(energy=c.energy, closure=c.closure, deformation=c.deformation,
                    rotation=c.rotation, min_step=c.min_step, spin=c.spin,
                    axial=c.axial)
    try:
        if a.fmus or a.controllers:
            r = _cosimulate(m, system, q0, a, limits, path)
        else:
            r = simulate(system, q0, m.qd0, (0.0, a.t_end), t_eval=_times(a),
                         method=a.method, rtol=a.rtol, atol=a.atol, progress=True,
                         formulation=a.formulation, max_steps=a.max_steps,
                         max_wall=a.max_wall, limits=limits, **opts)
    except ConfigError as exc:
        where = ("controllers",) if "sampled PID" in str(exc) else \
            ("fmus",) if a.fmus else ()
        raise m.workflow.error(*path, *where, msg=str(exc)) from None
    forces = {name: r.driver_forces[:, i] for i, name in enumerate(r.driven)}
    extra = {"closure_residual": r.closure_residual, "n_steps": r.n_steps, "n_rhs": r.n_rhs,
             "method": r.method, "formulation": r.formulation}
    if "error_seconds" in r.step_stats:  # a fixed step's error estimate: what it cost
        extra["error_estimate_seconds"] = r.step_stats["error_seconds"]
    if "error_ratio" in r.step_stats:  # the estimated error over the tolerance asked
        extra["error_ratio"] = r.step_stats["error_ratio"]
    if r.multipliers.size:
        extra["multipliers"] = r.multipliers
    return {
        "success": r.success,
        "message": r.message,
        "t": r.t,
        "q": r.q,
        "qd": r.qd,
        "qdd": r.qdd,
        "forces": forces,
        "energies": dict(r.energies),
        "extra": extra,
        "states": state_histories(system, r.states),
        "verdict": r.verdict,
        "warnings": tuple(r.warnings),
    }


def _cosimulate(m: Machine, system, q0, a, limits, path):
    """The dynamic analysis ``a`` with its FMUs and digital controllers beside the machine
    (pipeline.solver.cosim): the Simulator's inputs are what they drive; the outputs are
    the communication points (``macro_step``, by default the shortest controller
    period)."""
    from pipeline.kinematics.drivers import driver_from_dict
    from pipeline.solver.cosim import BLOCK, FMU, SampledPID, cosimulate, signal
    from pipeline.solver.simulator import Simulator

    wf = m.workflow
    blocks = [FMU(wf.base_dir / f.path, f.inputs, f.outputs, f.parameters, f.name)
              for f in a.fmus]
    for i, c in enumerate(a.controllers):
        ref = c.reference if not isinstance(c.reference, dict) else driver_from_dict(
            c.reference, wf.where(*path, "controllers", i, "reference"), wf.base_dir)
        blocks.append(SampledPID(c.measured, c.output, ref, c.kp, c.ki, c.kd, c.period,
                                 c.output_limits, c.tracking_time, c.feedforward, c.name))
    targets = list(dict.fromkeys(x for b in blocks for x in b.targets))
    macro = a.macro_step or min(c.period for c in a.controllers)
    try:
        sim = Simulator(system, q0, m.qd0, step=a.step, inputs=targets, rho_inf=a.rho_inf,
                        rtol=a.rtol, atol=a.atol)
    except ConfigError as exc:  # an input nothing in the machine takes: at its controller
        for i, c in enumerate(a.controllers):
            if f"input {c.output!r}" in str(exc):
                raise wf.error(*path, "controllers", i, "output", msg=str(exc)) from None
        raise
    for i, c in enumerate(a.controllers):
        try:
            if not c.measured.startswith(BLOCK):  # (the master checks those)
                signal(sim, c.measured)
        except ConfigError as exc:
            raise wf.error(*path, "controllers", i, "measured", msg=str(exc)) from None
    return cosimulate(sim, blocks, a.t_end, macro, progress=True, limits=limits,
                      coupling_error=a.coupling_error)


def state_histories(system, states: np.ndarray) -> dict:
    """{"<element>.<state>": (unit, (T,) values)} of the force elements' states (T, nz)."""
    return {name: (unit, states[:, i])
            for i, (name, unit) in enumerate(zip(system.state_names, system.state_units))}


def _released(m: Machine, loads, path):
    """The machine's system without the force elements named in ``loads`` (a static start's
    loads, released at t = 0)."""
    names = [f.name for f in m.system.forces]
    for i, name in enumerate(loads):
        if name not in names:
            raise m.workflow.error(*path, i, msg=f"expected a force element of this workflow, "
                                                 f"got {name!r} (force elements: {names})")
    if not loads:
        return m.system
    return replace(m.system, forces=tuple(f for f in m.system.forces if f.name not in loads))


def _start_states(m: Machine, t: float):
    """The force elements' states (cylinder pressures) at their start values, a hold
    pressure found at the initial pose and time t, s; None without such elements."""
    return m.system.initial_states(m.q0, t) if m.system.state_slices else None


def run_linearised(m: Machine, a, path) -> dict:
    q = m.q0
    msg = ""
    states = _start_states(m, a.t)  # the statics and the linear model about them
    if a.start == "static":
        r = static_equilibrium(m.system, m.q0, t=a.t, hold=_hold(m, a.hold, *path, "hold"),
                               z=states)
        if not r.success:
            return {
                "success": False,
                "message": f"static start: {r.message}",
                "t": np.array([a.t]),
                "q": r.q[None, :],
                "qd": np.zeros((1, r.q.size)),
                "qdd": np.zeros((1, r.q.size)),
            }
        q = r.q
    v = vibration_modes(m.system, q, t=a.t, hold=_hold(m, a.hold, *path, "hold"),
                        z_eq=states)
    k = min(a.count, v.omega.size)
    z = np.zeros((1, q.size))
    lm = v.model
    extra = {"frequencies_hz": v.frequencies_hz[:k], "omega": v.omega[:k],
             "damping_ratios": v.damping_ratios[:k], "shapes": v.shapes[:, :k],
             "shapes_q": v.shapes_q[:, :k], "M": lm.M, "K": lm.K, "C": lm.C, "B": lm.B,
             "x_coordinates": np.array(lm.coordinates, dtype=object)}
    if states is not None:
        extra.update(shapes_z=v.shapes_z[:, :k], G=lm.G, S=lm.S,
                     z_names=np.array(lm.state_names, dtype=object))
    return {
        "success": True,
        "message": msg,
        "t": np.array([a.t]),
        "q": q[None, :],
        "qd": z,
        "qdd": z.copy(),
        "extra": extra,
    }


RUNNERS = {"kinematic": run_kinematic, "static": run_static, "kinetostatic": run_kinetostatic,
           "dynamic": run_dynamic, "linearised": run_linearised}


def run_analysis(m: Machine, name: str) -> AnalysisResult:
    """Run analysis ``name`` of the machine's workflow (the machine is built for one case)."""
    wf = m.workflow
    i, a = next((i, a) for i, a in enumerate(wf.spec.analyses) if a.name == name)
    t0 = time.perf_counter()
    if a.initial is not None:
        from pipeline.workflow.build import initial_state

        q0, qd0 = initial_state(wf, m.mechanism, m.system.drivers, a.initial,
                                ("analyses", i, "initial"))
        m = replace(m, q0=q0, qd0=qd0)
    out = RUNNERS[a.type](m, a, ("analyses", i))
    result = AnalysisResult(
        name=a.name,
        type=a.type,
        case=wf.case,
        coordinates=m.mechanism.coordinates,
        timings={"total": time.perf_counter() - t0},
        **out,
    )
    if m.model_warnings and a.type != "kinematic":  # kinematics hold the modes at zero
        result = replace(result, warnings=tuple(result.warnings) + m.model_warnings,
                         verdict="suspect" if result.verdict == "ok" else result.verdict)
    return result
