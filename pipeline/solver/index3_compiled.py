"""The index-3 generalised-alpha step (:mod:`pipeline.solver.index3`) as compiled calls
(:mod:`pipeline.solver.dae_kernels`, the one implementation of its Newton iteration; its
numpy oracle is ``tests/solver/index3_numpy.py``).

:func:`stepper` returns the :class:`CompiledStepper` of a system; a force element without a
compiled form is called back from it (:mod:`pipeline.dynamics.forces.python_elements`).
Drivers and force histories are Python objects: they are evaluated here, once per step, and
handed to the kernel as numbers. :meth:`CompiledStepper.march` runs a stretch of fixed
steps in one call (the driver values of every step tabulated first), recording the outputs
it passes.
"""

from __future__ import annotations

import numpy as np

from pipeline.kinematics.partition import RANK_RTOL
from pipeline.solver import dae_kernels as K
from pipeline.solver.constrained import ConstrainedSystem
from pipeline.solver.dae_data import CompiledDae, compile_dae, force_factors
from pipeline.solver.generalized_alpha import coefficients, first_order_coefficients
from pipeline.solver.index3 import StepOutcome, StepState, powers

__all__ = ["CompiledStepper", "stepper"]

_WHY = {1: "newton", 2: "jump", 3: "evaluation"}


class CompiledStepper:
    """Steps of the index-3 generalised-alpha method (:mod:`pipeline.solver.index3`).

    Parameters
    ----------
    cs : ConstrainedSystem.
    data : its flat data (:func:`~pipeline.solver.dae_data.compile_dae`).
    rho_inf : spectral radius at infinite frequency, [0, 1].
    newton_rtol, newton_atol : the Newton corrections dq must fall below
        newton_atol * unit + newton_rtol * |q| per coordinate.
    closure_tol : largest weighted closure residual accepted (dimensionless: m per length
        scale, rad).
    unit : (n,) coordinate scales (1 rad, the length scale for a length, the modal amplitude
        that moves a frame by the length scale): the jump bound and atol are in these units.
    jump : largest Newton correction (in ``unit``) accepted before the step is rejected as
        leaving the predicted configuration (another assembly branch, a diverging Newton).
    eps : regularisation of the constraint block (relative).
    """

    def __init__(self, cs: ConstrainedSystem, data: CompiledDae, rho_inf=0.8,
                 newton_rtol=1e-8, newton_atol=1e-10, closure_tol=1e-10, unit=None, jump=0.1,
                 eps=1e-10):
        self.cs, self.data = cs, data
        self.am, self.af, self.beta, self.gamma = coefficients(rho_inf)
        self.par = np.array([self.am, self.af, self.beta, self.gamma, newton_rtol, newton_atol,
                             closure_tol, jump, eps, *first_order_coefficients(rho_inf)])
        self.unit = data.unit if unit is None else np.asarray(unit, dtype=float)
        self.eps = float(eps)
        #: the force elements' own states: their number and scales
        self.zunit = cs.system.state_scales()
        nk = cs.U.size + self.zunit.size
        self.S = np.zeros((nk, nk))
        self.sinfo = np.zeros(4)  # h of S (0: none), stale, Jacobians, evaluations
        self.args = (K.kin_tuple(data.kin), K.mass_tuple(data.masses), data.K, data.D,
                     data.gravity4, data.w, data.forces)

    @property
    def evaluations(self) -> int:
        return int(self.sinfo[3])

    @property
    def jacobians(self) -> int:
        return int(self.sinfo[2])

    def start(self, t: float, q: np.ndarray, v: np.ndarray, z=None) -> StepState:
        """The state at a consistent (q, v) (and the elements' states z; default their
        start values): its accelerations and multipliers (index-1 solve)."""
        cs = self.cs
        self.sinfo[3] += 1
        if not self.zunit.size:
            st = cs.evaluate(t, q, v)
            qdd, lam = cs.accelerations(st)
            return StepState(t, q.copy(), v.copy(), qdd, qdd.copy(), lam, powers(cs, st, v))
        z = cs.system.initial_states(q, t) if z is None else np.array(z, dtype=float)
        qdd, lam, zd, pd, pnc = K.start(q, v, z, cs.drive(t)[2], self._factors([t])[0], cs.U,
                                        cs.P, self.eps, *self.args)
        return StepState(t, q.copy(), v.copy(), qdd, qdd.copy(), lam, np.array([pd, pnc]),
                         z, zd, zd.copy())

    def reset(self):
        self.sinfo[0] = 0.0

    def memory(self):
        """A copy of what the next step reuses (the iteration matrix; :meth:`recall`)."""
        return self.S.copy(), self.sinfo[:2].copy()

    def recall(self, memory) -> None:
        """Reuse ``memory`` (from :meth:`memory`): the steps then repeat bit for bit."""
        self.S[:], self.sinfo[:2] = memory

    def _factors(self, times) -> np.ndarray:
        return force_factors(self.data, times)

    def step(self, s0: StepState, h: float) -> StepOutcome:
        cs = self.cs
        t1 = s0.t + h
        qP, vP, aP = cs.drive(t1)
        out = K.step(s0.q, s0.v, s0.qdd, s0.a, s0.lam, s0.z, s0.zd, s0.b, float(h), qP, vP,
                     aP, self._factors([t1])[0], self.par, self.unit, self.zunit, cs.U, cs.P,
                     self.S, self.sinfo, *self.args)
        status, q, v, qdd, a, lam, z, zd, b, it, moved, cerr, pd, pnc = out
        if status:
            return StepOutcome(None, int(it), _WHY[int(status)], float(moved), float(cerr))
        return StepOutcome(StepState(t1, q, v, qdd, a, lam, np.array([pd, pnc]), z, zd, b),
                           int(it), "", float(moved), float(cerr))

    def march(self, s0: StepState, h: float, count: int, work: np.ndarray, grid=None):
        """``count`` steps of size h from s0 in one call, recording the output times of
        ``grid`` (an OutputGrid, or None) they pass: (steps done, failure or "", (t, q, v,
        work, z, zd) before the last step done, the last state, work at it)."""
        cs = self.cs
        times = s0.t + h * np.arange(1, count + 1)
        qP, vP, aP = cs.drive_table(times)
        q, v, qdd, a, lam, z, zd, b = (x.copy() for x in (s0.q, s0.v, s0.qdd, s0.a, s0.lam,
                                                           s0.z, s0.zd, s0.b))
        w, p = np.array(work, dtype=float), np.array(s0.powers, dtype=float)
        te = np.zeros(0) if grid is None else grid.due_until(times[-1])
        full = grid is not None and not grid.positions_only
        if te.size and full:
            teP, tvP, taP = cs.drive_table(te)
            tfac = self._factors(te)
        else:
            teP = tvP = taP = np.zeros((te.size, cs.P.size))
            tfac = np.zeros((te.size, 2 * self.data.forces.kind.size))
        o, n, m, nz = te.size, cs.n, cs.m, z.size
        rec = (np.zeros((o, n)), np.zeros((o, n)), np.zeros((o, n)), np.zeros((o, m)),
               np.zeros((o, cs.P.size)), np.zeros((o, 4)), np.zeros(o), np.zeros((o, 2)),
               np.zeros((o, nz)))
        done, status, qprev, vprev, wprev, zprev, zdprev, _, ko = K.march(
            q, v, qdd, a, lam, z, zd, b, s0.t, float(h), qP, vP, aP, self._factors(times), w,
            p, self.par, self.unit, self.zunit, cs.U, cs.P, self.S, self.sinfo, *self.args,
            te, teP, tvP, taP, tfac, RANK_RTOL, full, *rec)
        if grid is not None and ko:  # their cost is in the call's (timings "integrate")
            grid.append_rows(zip(te[:ko], *(r[:ko] for r in rec)))
        done = int(done)
        t = s0.t + h * done
        last = StepState(t, q, v, qdd, a, lam, p, z, zd, b)
        before = (t - h, qprev, vprev, wprev, zprev, zdprev)
        return done, _WHY.get(int(status), ""), before, last, w

    def output(self, t: float, q: np.ndarray, v: np.ndarray, z=None):
        """(q, v, qdd, lam, driver forces, energies dict, closure residual) reported at t
        (and the elements' states z) (outputs.OutputGrid.record, compiled)."""
        cs = self.cs
        qP, vP, aP = cs.drive(t)
        z = np.zeros(0) if z is None else z
        q, v, qdd, lam, F, e, res, _ = K.output(q, v, z, qP, vP, aP, self._factors([t])[0],
                                                cs.U, cs.P, RANK_RTOL, *self.args)
        names = ("kinetic", "gravity", "elastic", "forces")
        return q, v, qdd, lam, F, {k: float(x) for k, x in zip(names, e)}, float(res)


    def index1(self, t: float, q: np.ndarray, v: np.ndarray, eps: float):
        """(q''_U, driver power, -dissipated power) of the index-1 form at (q, v) (drivers
        set), compiled (projected._Index1)."""
        cs = self.cs
        return K.index1_rhs(q, v, cs.drive(t)[2], self._factors([t])[0], cs.U, cs.P, eps,
                            *self.args)


def stepper(cs: ConstrainedSystem, warn: bool = True, **kw) -> CompiledStepper:
    """The compiled stepper of ``cs`` (keywords: :class:`CompiledStepper`'s; ``warn``: log
    the force elements called back in Python, if any)."""
    return CompiledStepper(cs, compile_dae(cs.system, cs.U, cs.P, warn), **kw)
