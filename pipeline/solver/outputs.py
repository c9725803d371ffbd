"""Outputs of a run of the constrained equations (both integrators of the DAE formulation).

Each output time gets a consistent state: positions and velocities (interpolated between
two step ends if needed) projected onto the constraints by least-norm changes of the
non-driven coordinates, then the accelerations and minimum-norm multipliers of that state
(the index-1 solve), its energies and the driver forces. So every output closes its loops
to 1e-12 whatever the step, and the reported multipliers are unique even where closure rows
are redundant.
"""

from __future__ import annotations

import time

import numpy as np

from pipeline.dynamics.energy import energies
from pipeline.solver.constrained import ConstrainedSystem, same_time
from pipeline.solver.dae_kernels import hermite
from pipeline.solver.result import ENERGY_KEYS, SimulationResult

__all__ = ["OutputGrid", "hermite", "same_time"]


class OutputGrid:
    """The output times ``te`` (s) and the rows recorded so far (``k`` of them)."""

    def __init__(self, cs: ConstrainedSystem, te: np.ndarray, compiled=None,
                 positions_only: bool = False):
        self.cs, self.te, self.k = cs, te, 0
        self.rows = []
        self.seconds = 0.0  # spent recording
        #: ``compiled(t, q, v)`` -> (q, v, qdd, lam, F, energies, residual): the same state
        #: from one compiled call (CompiledStepper.output), or None
        self.compiled = compiled
        #: record the interpolated q, v (and element states) only: no projection, no
        #: accelerations, forces or energies (a run made to compare positions, such as a
        #: fixed step's error estimate, where the full record was half its cost)
        self.positions_only = positions_only

    @property
    def done(self) -> bool:
        return self.k >= self.te.size

    def due(self, t: float) -> bool:
        """Is the next output time at or before t?"""
        return self.k < self.te.size and self.te[self.k] <= t + same_time(t)

    def fill_hermite(self, t0, q0, v0, w0, t1, q1, v1, w1, z=None):
        """Record every output time in (t0, t1] from the cubic Hermite interpolant of the
        step's end states; w: (driver work, dissipated energy) at each end, interpolated
        linearly; z: (z0, z0', z1, z1') the force elements' own states and their rates at
        the ends (Hermite too), or None without such states."""
        h = t1 - t0
        while self.due(t1):
            tk = self.te[self.k]
            if abs(tk - t1) <= same_time(t1):
                self.record(tk, q1, v1, w1, None if z is None else z[2])
                continue
            s = 0.0 if h <= 0 else min(max((tk - t0) / h, 0.0), 1.0)
            q, v = hermite(q0, v0, q1, v1, h, s)
            zk = None if z is None else hermite(z[0], z[1], z[2], z[3], h, s)[0]
            self.record(tk, q, v, (1.0 - s) * np.asarray(w0) + s * np.asarray(w1), zk)

    def due_until(self, t: float) -> np.ndarray:
        """The output times not yet recorded up to t (s)."""
        j = self.k
        while j < self.te.size and self.te[j] <= t + same_time(t):
            j += 1
        return self.te[self.k:j]

    def append_rows(self, rows) -> None:
        """Append rows recorded by the compiled march (t, q, v, qdd, lam, F, energies (4,),
        residual, work (2,), z), in time order."""
        names = ("kinetic", "gravity", "elastic", "forces")
        for t, q, v, qdd, lam, F, e, res, work, z in rows:
            self._append(t, q, v, qdd, lam, F, dict(zip(names, map(float, e))), float(res),
                         work, z)

    def record(self, t, q, v, work, z=None):
        """Project (q, v) at t, evaluate and append an output row (z: the elements' own
        states there, if the system has any)."""
        tic = time.perf_counter()
        try:
            self._record(t, q, v, work, np.zeros(0) if z is None else np.asarray(z))
        finally:
            self.seconds += time.perf_counter() - tic

    def _record(self, t, q, v, work, z):
        if self.positions_only:
            cs = self.cs
            e = dict.fromkeys(("kinetic", "gravity", "elastic", "forces"), 0.0)
            self._append(t, np.array(q), np.array(v), np.zeros(cs.n), np.zeros(cs.m),
                         np.zeros(cs.P.size), e, 0.0, work, z)
            return
        if self.compiled is not None:
            q, v, qdd, lam, F, e, res = self.compiled(t, q, v, z)
            self._append(t, q, v, qdd, lam, F, e, res, work, z)
            return
        cs = self.cs
        q = cs.project_positions(t, q)
        _, v = cs.with_drivers(t, q, v)
        st = cs.evaluate(t, q, v)
        if cs.m:
            v = cs.project_velocities(st, v)
            st = cs.evaluate(t, q, v)
        qdd, lam = cs.accelerations(st)
        e = energies(cs.system, st.terms.tree, q, v, M=st.terms.M)
        res = float(np.abs(st.c / cs.w).max()) if cs.m else 0.0
        self._append(t, q, v, qdd, lam, cs.driver_forces(st, qdd, lam), e, res, work, z)

    def _append(self, t, q, v, qdd, lam, F, e, res, work, z):
        e["driver_work"], e["dissipated"] = float(work[0]), float(work[1])
        e["total"] = (e["kinetic"] + e["gravity"] + e["elastic"] + e["forces"] + e["dissipated"]
                      - e["driver_work"])
        self.rows.append((t, q, v, qdd, e, res, F, lam, np.array(z, dtype=float)))
        self.k += 1

    def result(self, msg, steps, n_eval, total, method, stats) -> SimulationResult:
        """The SimulationResult of the rows recorded (partial when ``msg`` is set); total: the
        run's wall seconds (split into integration and output)."""
        cs, rows = self.cs, self.rows
        timings = {"integrate": total - self.seconds, "output": self.seconds, "total": total}
        n, k = cs.n, len(rows)
        names = cs.system.mechanism.coordinates

        def stack(j, w):
            return np.array([r[j] for r in rows]).reshape(k, w)

        en = {key: np.array([r[4][key] for r in rows]) for key in ENERGY_KEYS}
        return SimulationResult(
            success=msg is None, status=0 if msg is None else -1,
            message="finished" if msg is None else msg, coordinates=names,
            t=np.array([r[0] for r in rows]), q=stack(1, n), qd=stack(2, n),
            qdd=stack(3, n), energies=en, closure_residual=np.array([r[5] for r in rows]),
            n_steps=steps, n_rhs=n_eval, timings=timings, method=method,
            driven=tuple(names[i] for i in cs.P), driver_forces=stack(6, cs.P.size),
            multipliers=stack(7, cs.m), step_stats=stats, formulation="dae",
            state_names=cs.system.state_names,
            states=stack(8, len(cs.system.state_names)))
