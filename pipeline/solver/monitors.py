"""Trust checks on every transient result: a run that violates its own checks says so.

Each check compares a figure of the run with a limit (:class:`Limits`); a check that trips
adds a warning naming the quantity, the time and the figure, and turns an "ok" run into a
"suspect" one (a stopped run stays "partial"):

* energy balance: T + V + E_dissipated - W_drivers should stay constant; its largest change
  from the start, relative to the energy the run exchanged (the largest kinetic, potential
  change, dissipated or driver work), must stay below ``energy``;
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

Examples
--------
>>> Limits().energy
0.01
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.solver.result import SimulationResult

__all__ = ["Limits", "StallWatch", "check", "judge", "link_sizes"]


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

    def __post_init__(self):
        for k in ("energy", "closure", "deformation", "rotation", "min_step", "spin"):
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
    parts = [np.abs(e["kinetic"])] + [np.abs(np.asarray(e[k]) - e[k][0]) for k in
                                       ("gravity", "elastic", "forces")] + \
            [np.abs(e["dissipated"]), np.abs(e["driver_work"])]
    scale = float(max(p.max() for p in parts))
    floor = 1e-9 + 1e-9 * float(max(np.abs(np.asarray(e[k])).max() for k in e))
    k = int(np.argmax(drift))
    if drift[k] > lim.energy * scale + floor:
        return [(f"energy balance off by {drift[k]:.4g} J at t = {r.t[k]:.6g} s "
                 f"({100 * drift[k] / max(scale, 1e-300):.3g} % of the {scale:.4g} J "
                 f"exchanged; limit {100 * lim.energy:g} %)")]
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


def _spin(system, r: SimulationResult, lim: Limits, samples: int = 200) -> list[str]:
    """Links with linear modes that spin fast enough for centrifugal stiffening to matter."""
    from pipeline.kinematics import evaluate_tree
    from pipeline.kinematics.rotations import vee

    mech = system.mechanism
    todo = [(name, body) for name, body in system.bodies.items()
            if body.n_modes and not body.second_order_moments.size]
    if not todo or not r.t.size:
        return []
    picks = np.unique(np.linspace(0, r.t.size - 1, min(samples, r.t.size)).round().astype(int))
    spin2 = {name: np.zeros(picks.size) for name, _ in todo}
    for j, k in enumerate(picks):
        if not (np.all(np.isfinite(r.q[k])) and np.all(np.isfinite(r.qd[k]))):
            continue
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


def _step_error(r: SimulationResult) -> list[str]:
    """A fixed-step run whose estimated error (:mod:`pipeline.solver.step_error`) exceeds
    the tolerance the user gave."""
    ratio = (r.step_stats or {}).get("error_ratio")
    if ratio is None or ratio <= 1.0:
        return []
    h = r.step_stats.get("h_max", 0.0)
    return [(f"the fixed step {h:.3g} s gives an estimated error of {ratio:.3g} x the "
             f"tolerance (rtol, atol), largest in {r.step_stats['error_coordinate']} at "
             f"t = {r.step_stats['error_time']:.4g} s (the run again at twice the step); "
             f"about {h / ratio:.2g} s would meet it, or omit the step for error control")]


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
                 + _spin(system, r, limits) + _step_error(r) + _steps(r, limits, span))


def judge(system, r: SimulationResult, limits: Limits = Limits(),
          t_span: tuple[float, float] | None = None) -> SimulationResult:
    """``r`` with its checks' warnings and verdict ("ok", "suspect" or "partial")."""
    warnings = check(system, r, limits, t_span)
    verdict = "partial" if not r.success else ("suspect" if warnings else "ok")
    return replace(r, verdict=verdict, warnings=warnings)
