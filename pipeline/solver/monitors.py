"""Trust checks on every transient result: a run that violates its own checks says so.

Each check compares a figure of the run with a limit (:class:`Limits`); a check that trips
adds a warning naming the quantity, the time and the figure, and turns an "ok" run into a
"suspect" one (a stopped run stays "partial"):

* energy balance: T + V + E_dissipated - W_drivers should stay constant; its largest change
  from the start, relative to the energy the run exchanged between forms (the largest
  change of the kinetic or a potential energy, the dissipated energy or the driver work --
  not the energy stored: a fast top's spin energy hides nothing), must stay below
  ``energy``, with :data:`ENERGY_NOISE` of the stored energy allowed as noise;
* closure: the largest loop-closure residual at the outputs below ``closure`` (m, rad);
* deformation range: the reduced links are linear models; the largest elastic displacement
  of a link's frames (and its mass-weighted RMS displacement) relative to the link's size
  below ``deformation``, the largest elastic frame rotation below ``rotation`` rad;
* step size: the smallest accepted step above ``min_step`` times the span;
* integration error: a fixed-step run's error, estimated by running it again at twice the
  step (:mod:`pipeline.solver.step_error`), within the tolerance the user gave (rtol, atol);
* physics left out: a flexible link reduced without geometric stiffening (linear modes)
  that spins at Omega with Omega^2 / omega_1^2 above ``spin`` (omega_1 its lowest kept
  frequency): centrifugal stiffening then moves omega_1^2 by about that share (a
  cantilever's flapwise mode: omega^2 + 1.19 Omega^2), and a linear model spun past
  omega_1 diverges.
* physics left out: such a link whose joints load it axially with |N| above ``axial``
  times its Euler load (:func:`euler_loads`): stiffening in tension and softening in
  compression change its bending by about that share (a fast slider-crank's rod).

Examples
--------
>>> Limits().energy
0.01
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from pipeline.core.errors import ConfigError, PipelineError
from pipeline.solver.result import SimulationResult

logger = logging.getLogger(__name__)

__all__ = ["ENERGY_NOISE", "Limits", "StallWatch", "check", "euler_loads", "judge",
           "link_sizes"]

#: energy drift below this share of the largest energy stored is integration noise
ENERGY_NOISE = 1e-6


@dataclass(frozen=True)
class Limits:
    """Thresholds of the trust checks (see the module docstring)."""

    energy: float = 1e-2
    closure: float = 1e-6
    # the linear limit of Adams Solver's flexible-body check (10 % of a characteristic
    # length), and the tip rotation of a cantilever at that deflection (1.5 x 0.1 rad)
    deformation: float = 0.10
    rotation: float = 0.15
    min_step: float = 1e-9
    spin: float = 0.05
    axial: float = 0.05

    def __post_init__(self):
        for k in ("energy", "closure", "deformation", "rotation", "min_step", "spin", "axial"):
            v = getattr(self, k)
            if not (isinstance(v, int | float) and np.isfinite(v) and v > 0):
                raise ConfigError(f"limits: {k}: expected a number > 0, got {v!r}")


class StallWatch:
    """Stops a run whose steps no longer advance time: ``window`` accepted steps that
    together cover less than ``fraction`` of the span (a step size collapsed near a
    singular or discontinuous place, which would otherwise run for hours)."""

    def __init__(self, span: float, window: int = 10_000, fraction: float = 1e-3):
        self.span, self.fraction = span, fraction
        self.times: deque[float] = deque(maxlen=window + 1)

    @property
    def window(self) -> int:
        return self.times.maxlen - 1

    def __call__(self, t: float) -> str | None:
        """Record an accepted step ending at t (s); a message if the run stalls."""
        self.times.append(t)
        if len(self.times) == self.times.maxlen:
            t0 = self.times[0]
            if t - t0 < self.fraction * self.span:
                return (f"the step size collapsed: the last {self.window} steps advanced time "
                        f"by only {t - t0:.3g} s (t = {t:.6g} s)")
        return None


def _energy(r: SimulationResult, lim: Limits) -> list[str]:
    if r.t.size < 2:
        return []
    e = r.energies
    total = np.asarray(e["total"])
    drift = np.abs(total - total[0])
    # what moves between forms, not what is stored: a top spinning with 250 J exchanges
    # 0.015 J with gravity, and its drift is judged against the 0.015 J
    parts = [np.abs(np.asarray(e[k]) - e[k][0]) for k in
             ("kinetic", "gravity", "elastic", "forces")] + \
            [np.abs(e["dissipated"]), np.abs(e["driver_work"])]
    scale = float(max(p.max() for p in parts))
    # a relative 1e-6 of the energy stored is the integration's noise, not a finding (unless
    # the user asks for a tighter balance)
    noise = min(ENERGY_NOISE, lim.energy)
    floor = 1e-9 + noise * float(max(np.abs(np.asarray(e[k])).max() for k in e))
    k = int(np.argmax(drift))
    if drift[k] > lim.energy * scale + floor:
        return [(f"energy balance off by {drift[k]:.4g} J at t = {r.t[k]:.6g} s "
                 f"({100 * drift[k] / max(scale, 1e-300):.3g} % of the {scale:.4g} J "
                 f"exchanged between kinetic, potential, dissipated and driver work; limit "
                 f"{100 * lim.energy:g} %)")]
    return []


def _closure(r: SimulationResult, lim: Limits) -> list[str]:
    c = np.asarray(r.closure_residual)
    if c.size and (not np.all(np.isfinite(c)) or c.max() > lim.closure):
        k = int(np.nanargmax(np.where(np.isfinite(c), c, np.inf)))
        return [(f"loop closure residual {c[k]:.3g} (m, rad) at t = {r.t[k]:.6g} s "
                 f"(limit {lim.closure:g})")]
    return []


def link_sizes(system) -> dict[str, float]:
    """Characteristic size (m) of every flexible link: the largest distance between its body
    origin, its frames and twice its radius of gyration."""
    mech = system.mechanism
    out = {}
    for name, body in system.bodies.items():
        li = mech.link_index(name)
        if not mech.modal_index[li].size:
            continue
        pts = [f.pose[:3, 3] for f in mech.links[li].frames] + [np.zeros(3)]
        size = max(np.linalg.norm(a - b) for a in pts for b in pts)
        m = body.C[3, 3]
        if m > 0:
            com = body.C[:3, 3] / m
            rg2 = max(np.trace(body.C[:3, :3]) / m - com @ com, 0.0)
            size = max(size, 2.0 * np.sqrt(rg2))
        out[name] = float(size) if size > 0 else float(mech.length_scale)
    return out


def _deformation(system, r: SimulationResult, lim: Limits) -> list[str]:
    mech = system.mechanism
    out = []
    for name, size in link_sizes(system).items():
        li = mech.link_index(name)
        idx = mech.modal_index[li]
        eta = np.asarray(r.q)[:, idx]
        if not eta.size:
            continue
        frames = mech.links[li].frames
        u = max((np.linalg.norm(eta @ f.phi, axis=1) for f in frames),
                key=lambda x: x.max(initial=0.0))
        th = max((np.linalg.norm(eta @ f.psi, axis=1) for f in frames),
                 key=lambda x: x.max(initial=0.0))
        body = system.bodies[name]
        rms = np.sqrt(np.maximum(np.einsum("ta,ab,tb->t", eta, _modal_mass(body), eta), 0.0)
                      / body.C[3, 3])
        u = np.maximum(u, rms)
        if not np.all(np.isfinite(u)) or u.max() > lim.deformation * size:
            k = int(np.nanargmax(np.where(np.isfinite(u), u, np.inf)))
            out.append(f"link '{name}' deforms by {u[k]:.4g} m at t = {r.t[k]:.6g} s "
                       f"({100 * u[k] / size:.3g} % of its {size:.4g} m size; the linear "
                       f"reduced model holds to about {100 * lim.deformation:g} %)")
        elif th.max(initial=0.0) > lim.rotation:
            k = int(np.argmax(th))
            out.append(f"link '{name}' frames turn elastically by {th[k]:.3g} rad at "
                       f"t = {r.t[k]:.6g} s (the linear reduced model holds to about "
                       f"{lim.rotation:g} rad)")
    return out


def _modal_mass(body) -> np.ndarray:
    """(m, m) translational modal mass tr C''_ab of a flexible body, kg per modal unit^2."""
    return np.einsum("abii->ab", body.Cpp[:, :, :3, :3])


def _linear_links(system) -> list[tuple[str, object]]:
    """(name, body) of the flexible links reduced without geometric stiffening."""
    return [(name, body) for name, body in system.bodies.items()
            if body.n_modes and not body.second_order_moments.size]


def _samples(r: SimulationResult, samples: int, *states) -> list[int]:
    """Up to ``samples`` output rows spread over the run whose ``states`` ("q", "qd",
    "qdd") are all finite."""
    picks = np.unique(np.linspace(0, r.t.size - 1, min(samples, r.t.size)).round().astype(int))
    return [int(k) for k in picks
            if all(np.all(np.isfinite(getattr(r, x)[k])) for x in states)]


def _spin(system, r: SimulationResult, lim: Limits, samples: int = 200) -> list[str]:
    """Links with linear modes that spin fast enough for centrifugal stiffening to matter."""
    from pipeline.kinematics import evaluate_tree
    from pipeline.kinematics.rotations import vee

    mech = system.mechanism
    todo = _linear_links(system)
    if not todo or not r.t.size:
        return []
    picks = _samples(r, samples, "q", "qd")
    if not picks:
        return []
    spin2 = {name: np.zeros(len(picks)) for name, _ in todo}
    for j, k in enumerate(picks):
        tree = evaluate_tree(mech, r.q[k], r.qd[k], derivatives=False)
        for name, _ in todo:
            li = mech.link_index(name)
            omega = vee(tree.Ad[li, :3, :3] @ tree.A[li, :3, :3].T)  # ground axes
            spin2[name][j] = float(omega @ omega)
    out = []
    for name, body in todo:
        w1 = float(np.min(np.linalg.eigvals(np.linalg.solve(_modal_mass(body),
                                                             body.stiffness)).real))
        j = int(np.argmax(spin2[name]))
        ratio = spin2[name][j] / w1 if w1 > 0 else np.inf
        if ratio > lim.spin:
            out.append(f"link '{name}' spins at up to {np.sqrt(spin2[name][j]):.4g} rad/s "
                       f"(t = {r.t[picks[j]]:.6g} s), Omega^2 = {ratio:.3g} x its lowest "
                       f"kept omega^2 ({np.sqrt(w1) / (2 * np.pi):.4g} Hz): centrifugal "
                       f"stiffening moves that frequency by the order of {100 * ratio:.3g} % "
                       f"and the model leaves it out (limit {lim.spin:g}); reduce the link "
                       f"with geometric stiffening (links.{name}.geometric_stiffening: true)")
    return out


def euler_loads(mech, name: str, body) -> dict[str, tuple[np.ndarray, float]]:
    """{frame: (unit axis (3,), N_cr)} of a flexible link: for each frame away from its
    body origin (the reference), the axis from the origin to the frame (body axes) and the
    Euler load pi^2 EI / l^2 of a pinned strut of that length l, N, whose EI is what the
    kept modes give the link in bending along it.

    EI is read from the kept modes' static compliance, transverse to the axis: at the frame
    itself as a cantilever from the reference (c = l^3 / 3 EI: clamped or Craig-Bampton
    modes), or, at a frame part-way along (s from the origin, near the axis), relative to
    the chord (c = s^2 (l - s)^2 / 3 EI l: a pin-pin beam, chord modes), the softest
    transverse direction and the softest of these. A frame the kept modes do not bend
    along its axis is left out.
    """
    li = mech.link_index(name)
    frames = mech.links[li].frames
    K = np.asarray(body.stiffness, dtype=float)
    flex = np.linalg.pinv(K, rcond=1e-12)
    pos = {f.name: np.asarray(f.pose[:3, 3], dtype=float) for f in frames}
    reach = max((np.linalg.norm(p) for p in pos.values()), default=0.0)
    out = {}
    for f in frames:
        ell = float(np.linalg.norm(pos[f.name]))
        if ell <= 1e-6 * reach:
            continue
        e = pos[f.name] / ell
        P = np.eye(3) - np.outer(e, e)
        end = np.asarray(f.phi, dtype=float) @ P  # (m, 3) transverse motion at the frame
        ei = []
        c = np.linalg.eigvalsh(end.T @ flex @ end)[-1]
        if c > 0:
            ei.append(ell ** 3 / (3.0 * c))
        for g in frames:
            s_ = float(pos[g.name] @ e)
            if not (0.05 * ell < s_ < 0.95 * ell) or \
                    np.linalg.norm(P @ pos[g.name]) > 0.25 * ell:
                continue
            rel = np.asarray(g.phi, dtype=float) @ P - (s_ / ell) * end
            c = np.linalg.eigvalsh(rel.T @ flex @ rel)[-1]
            if c > 0:
                ei.append(s_ ** 2 * (ell - s_) ** 2 / (3.0 * ell * c))
        if ei:
            out[f.name] = (e, float(np.pi ** 2 * min(ei) / ell ** 2))
    return out


def _axial_load(system, r: SimulationResult, lim: Limits, samples: int = 50) -> list[str]:
    """Links with linear modes whose joints load them axially near enough their Euler load
    for geometric stiffening (or softening, in compression) to matter."""
    from pipeline.dynamics.kinetostatics import joint_reactions
    from pipeline.kinematics import evaluate_tree

    mech = system.mechanism
    ends = {name: euler_loads(mech, name, body) for name, body in _linear_links(system)}
    ends = {k: v for k, v in ends.items() if v}
    at = [(j, link, frame, sign) for j, joint in enumerate(mech.joints)
          for link, frame, sign in ((joint.child, joint.child_frame, 1.0),
                                    (joint.parent, joint.parent_frame, -1.0))
          if frame in ends.get(link, {})]
    if not at or not r.t.size or r.qdd is None:
        return []
    opaque = [getattr(f, "name", type(f).__name__) for f in system.forces
              if not (hasattr(f, "coordinate") or hasattr(f, "loads"))]
    if opaque:  # known only by its generalized force: no joint reactions to read
        logger.warning("the axial-load check of %s is skipped: force element(s) %s give no "
                       "loads (Load list) for the joint reactions", sorted(ends), opaque)
        return []
    worst: dict[str, tuple] = {}
    driven = list(r.driven or ())
    failed, read = None, 0
    for k in _samples(r, samples, "q", "qd", "qdd"):
        act = dict(zip(driven, np.asarray(r.driver_forces)[k])) if driven else {}
        try:
            rx = joint_reactions(system, r.q[k], r.qd[k], r.qdd[k], float(r.t[k]), act,
                                 r.states[k] if r.states.size else None)
        except (PipelineError, FloatingPointError, np.linalg.LinAlgError) as exc:
            failed = exc  # a force element that fails there: the run says so itself
            continue
        read += 1
        A = evaluate_tree(mech, r.q[k], derivatives=False).A
        for j, link, frame, sign in at:
            e, ncr = ends[link][frame]
            N = sign * float(rx.force[j] @ (A[mech.link_index(link), :3, :3] @ e))
            if abs(N) / ncr > worst.get(link, (0.0,))[0]:
                worst[link] = (abs(N) / ncr, N, ncr, frame, float(r.t[k]))
    if failed is not None and not read:
        logger.warning("the axial-load check of %s is skipped: the joint reactions could "
                       "not be computed at any sampled time (%s)", sorted(ends), failed)
    out = []
    for link, (ratio, N, ncr, frame, t) in worst.items():
        if ratio > lim.axial:
            kind = "compression" if N < 0 else "tension"
            out.append(f"link '{link}' carries {abs(N):.4g} N of axial {kind} at '{frame}' "
                       f"(t = {t:.6g} s), {ratio:.3g} x its Euler load of about {ncr:.4g} N "
                       f"(from its kept modes' bending stiffness): geometric "
                       f"{'softening' if N < 0 else 'stiffening'} changes its bending by the "
                       f"order of {100 * ratio:.3g} % and the model leaves it out (limit "
                       f"{lim.axial:g}); reduce the link with geometric stiffening "
                       f"(links.{link}.geometric_stiffening: true)")
    return out


def _step_error(r: SimulationResult) -> list[str]:
    """A fixed-step run whose estimated error (:mod:`pipeline.solver.step_error`) exceeds
    the tolerance the user gave."""
    why = (r.step_stats or {}).get("error_unavailable")
    if why:
        h = r.step_stats.get("h_max", 0.0)
        return [(f"the error of the fixed step {h:.3g} s could not be estimated ({why}), so "
                 f"the run is not known to be within its tolerance; a smaller step, or no "
                 f"step (error control), makes it so")]
    ratio = (r.step_stats or {}).get("error_ratio")
    if ratio is None or ratio <= 1.0:
        return []
    h = r.step_stats.get("h_max", 0.0)
    return [(f"the fixed step {h:.3g} s gives an estimated error of {ratio:.3g} x the "
             f"tolerance (rtol, atol), largest in {r.step_stats['error_coordinate']} at "
             f"t = {r.step_stats['error_time']:.4g} s "
             f"({r.step_stats.get('error_method', 'the run again at twice the step')}); "
             f"about {h / ratio:.2g} s would meet it, or omit the step for error control")]


def _coupling_error(r: SimulationResult) -> list[str]:
    """A co-simulation whose estimated coupling error (:func:`pipeline.solver.cosim.
    coupling_estimate`) exceeds the tolerance the user gave."""
    s = r.step_stats or {}
    H = s.get("macro_step", 0.0)
    why = s.get("coupling_unavailable")
    if why:
        return [(f"the coupling error of the co-simulation's macro step {H:.3g} s could not "
                 f"be estimated ({why}), so the run is not known to be within its tolerance")]
    ratio = s.get("coupling_ratio")
    if ratio is None or ratio <= 1.0:
        return []
    return [(f"the co-simulation's macro step {H:.3g} s gives an estimated coupling error "
             f"(the blocks' outputs held over each macro step) of {ratio:.3g} x the "
             f"tolerance (rtol, atol), largest in {s['coupling_coordinate']} at t = "
             f"{s['coupling_time']:.4g} s ({s.get('coupling_method', '')}); about "
             f"{H / ratio:.2g} s would meet it, or coupling_error false where a block is a "
             f"digital controller sampled at the macro step by design")]


def _steps(r: SimulationResult, lim: Limits, span: float) -> list[str]:
    hmin = r.step_stats.get("h_min") if r.step_stats else None
    if hmin and r.n_steps and hmin < lim.min_step * span:
        return [(f"the step size collapsed to {hmin:.3g} s (limit {lim.min_step:g} of the "
                 f"{span:g} s span)")]
    return []


def check(system, r: SimulationResult, limits: Limits = Limits(),
          t_span: tuple[float, float] | None = None) -> tuple[str, ...]:
    """The warnings of every check that trips on ``r`` (empty: all hold)."""
    span = (t_span[1] - t_span[0]) if t_span else (float(r.t[-1] - r.t[0]) if r.t.size else 1.0)
    return tuple(_energy(r, limits) + _closure(r, limits) + _deformation(system, r, limits)
                 + _spin(system, r, limits) + _axial_load(system, r, limits) + _step_error(r)
                 + _coupling_error(r) + _steps(r, limits, span) + _elements(system, r))


def _elements(system, r: SimulationResult) -> list[str]:
    """What the force elements find in the run that their models leave out (an element's
    ``run_checks``: a hydraulic cylinder past its ends or cavitating)."""
    return [w for f in system.forces if hasattr(f, "run_checks") for w in f.run_checks(system, r)]


def judge(system, r: SimulationResult, limits: Limits = Limits(),
          t_span: tuple[float, float] | None = None) -> SimulationResult:
    """``r`` with its checks' warnings and verdict ("ok", "suspect" or "partial")."""
    warnings = check(system, r, limits, t_span)
    verdict = "partial" if not r.success else ("suspect" if warnings else "ok")
    return replace(r, verdict=verdict, warnings=warnings)
