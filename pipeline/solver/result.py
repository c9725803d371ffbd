"""SimulationResult: the time history of one run, saved atomically as NPZ or CSV."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from pipeline.core.atomic import atomic_open, save_npz_atomic

__all__ = ["ENERGY_KEYS", "SimulationResult"]

#: Energy histories kept per output time (J): kinetic, gravity potential,
#: modal strain, force-element potentials, energy removed by the
#: non-conservative terms (damping, dampers, non-conservative forces), work
#: done by the drivers, and total = T + V + dissipated - driver_work
#: (constant up to the integration error).
ENERGY_KEYS = ("kinetic", "gravity", "elastic", "forces", "dissipated", "driver_work", "total")


@dataclass(frozen=True)
class SimulationResult:
    """Outcome of :func:`pipeline.solver.simulate` (partial history when it failed).

    Attributes
    ----------
    success : True when t_span was reached.
    status : 0 finished, -1 integration failure (step size, singular position, ...).
    message : what happened (the failure reason with its time).
    coordinates : names of the n coordinates.
    t : (k,) output times reached, s.
    q, qd, qdd : (k, n) coordinates, rates, accelerations.
    energies : name -> (k,) J (see ``ENERGY_KEYS``).
    closure_residual : (k,) max |closure residual| (m or rad) per output time.
    n_steps, n_rhs : accepted steps and right-hand-side evaluations.
    timings : seconds per stage ("integrate", "output", "total"); a fixed-step
        generalised-alpha run records its outputs inside the compiled steps, and their
        cost is then part of "integrate".
    method : integrator name.
    driven : names of the driven coordinates.
    driver_forces : (k, p) force (N) / torque (N m) each driver applies along
        its coordinate (e.g. a prescribed-length cylinder's force).
    reselections : times (s) at which the independent coordinates were re-selected.
    multipliers : (k, m) multipliers of the weighted closure rows (DAE formulation; the
        minimum-norm ones where rows are redundant), N m per unit row.
    step_stats : accepted/rejected steps, smallest and largest step, evaluations.
    formulation : "dae" or "partitioned".
    verdict : "ok", "suspect" (finished, but a trust check tripped: see ``warnings``) or
        "partial" (stopped early: see ``message``).
    warnings : what each tripped trust check found (:mod:`pipeline.solver.monitors`).
    state_names : names ``<element>.<state>`` of the force elements' own states.
    states : (k, nz) their values (a hydraulic cylinder's chamber pressures, Pa).
    """

    success: bool
    status: int
    message: str
    coordinates: tuple[str, ...]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    energies: Mapping[str, np.ndarray]
    closure_residual: np.ndarray
    n_steps: int
    n_rhs: int
    timings: Mapping[str, float] = field(default_factory=dict)
    method: str = ""
    driven: tuple[str, ...] = ()
    driver_forces: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    reselections: tuple[float, ...] = ()
    multipliers: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    step_stats: Mapping[str, float] = field(default_factory=dict)
    formulation: str = "partitioned"
    verdict: str = ""
    warnings: tuple[str, ...] = ()
    state_names: tuple[str, ...] = ()
    states: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def __post_init__(self) -> None:
        object.__setattr__(self, "energies", MappingProxyType(dict(self.energies)))
        object.__setattr__(self, "timings", MappingProxyType(dict(self.timings)))
        object.__setattr__(self, "step_stats", MappingProxyType(dict(self.step_stats)))
        object.__setattr__(self, "coordinates", tuple(self.coordinates))
        object.__setattr__(self, "driven", tuple(self.driven))
        object.__setattr__(self, "reselections", tuple(self.reselections))
        object.__setattr__(self, "warnings", tuple(self.warnings))
        object.__setattr__(self, "state_names", tuple(self.state_names))
        if not self.verdict:
            object.__setattr__(self, "verdict", "ok" if self.success else "partial")

    @property
    def report(self) -> str:
        """One paragraph: verdict, message and every warning."""
        return "; ".join([f"{self.verdict}: {self.message}", *self.warnings])

    def coordinate(self, name: str) -> np.ndarray:
        """(k,) history of coordinate ``name``."""
        return self.q[:, self.coordinates.index(name)]

    def state(self, name: str) -> np.ndarray:
        """(k,) history of a force element's own state ``name`` (``<element>.<state>``)."""
        return self.states[:, self.state_names.index(name)]

    def save_npz(self, path):
        """Write every array and the scalars to ``path`` (.npz) atomically; returns the path."""
        arrays = {"t": self.t, "q": self.q, "qd": self.qd, "qdd": self.qdd,
                  "closure_residual": self.closure_residual,
                  "coordinates": np.array(self.coordinates, dtype=str),
                  "success": np.array(self.success), "status": np.array(self.status),
                  "message": np.array(self.message), "method": np.array(self.method),
                  "n_steps": np.array(self.n_steps), "n_rhs": np.array(self.n_rhs),
                  "driven": np.array(self.driven, dtype=str),
                  "driver_forces": self.driver_forces,
                  "reselections": np.array(self.reselections, dtype=float),
                  "multipliers": self.multipliers, "formulation": np.array(self.formulation),
                  "verdict": np.array(self.verdict),
                  "warnings": np.array(self.warnings, dtype=str),
                  "state_names": np.array(self.state_names, dtype=str),
                  "states": self.states}
        arrays.update({f"energy_{k}": v for k, v in self.energies.items()})
        arrays.update({f"timing_{k}": np.array(v) for k, v in self.timings.items()})
        return save_npz_atomic(path, **arrays)

    def save_csv(self, path):
        """Write one row per output time (t, q, qd, qdd, energies, residual) atomically."""
        cols = (["t"] + list(self.coordinates) + [f"d({c})" for c in self.coordinates]
                + [f"dd({c})" for c in self.coordinates]
                + [f"energy_{k}" for k in self.energies] + ["closure_residual"]
                + [f"force({c})" for c in self.driven] + list(self.state_names))
        data = np.column_stack([self.t, self.q, self.qd, self.qdd]
                               + [np.asarray(v) for v in self.energies.values()]
                               + [self.closure_residual, self.driver_forces.reshape(
                                   self.t.size, -1), self.states.reshape(self.t.size, -1)]
                               ) if self.t.size else np.zeros((0, len(cols)))
        with atomic_open(path, "w", newline="") as fh:
            fh.write(f"# verdict={self.verdict} status={self.status} message={self.message}"
                     + "".join(f" | warning: {w}" for w in self.warnings) + "\n")
            np.savetxt(fh, data, delimiter=",", header=",".join(cols), comments="",
                       fmt="%.17g")
        return path
