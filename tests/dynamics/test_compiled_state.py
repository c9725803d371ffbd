"""The fused compiled reduced state (pipeline.dynamics.compiled.closed_state and
reduced_solve, reduced_state's one path for closed loops) against a numpy reference kept
here (position analysis, velocity map, closure rates, the reduced equations solved in
numpy), on the flexible four-bar free and with a driven crank, including starts far from
the closed configuration and the fallback to the damped position analysis."""

from __future__ import annotations

import numpy as np
import pytest
from eom_models import flexible_four_bar

from pipeline.dynamics import System, partition
from pipeline.dynamics.equations import equation_terms
from pipeline.dynamics.partition import ReducedState, driver_state, partition_system, reduced_state
from pipeline.kinematics import assemble
from pipeline.kinematics.analysis import solve_position, velocity_map
from pipeline.kinematics.closure import closure_rates
from pipeline.kinematics.drivers import SmoothStep

FIELDS = ("q", "qd", "qdd", "qdd_I", "B", "Bp", "driver_forces", "J")


def _system(driven: bool):
    s = flexible_four_bar(n_modes=2).system
    mech = s.mechanism
    q0 = mech.q_initial.copy()
    q0[mech.modal_coordinates] = [0.05, -0.03]
    q0 = assemble(mech, q0).q
    if driven:
        s = System(mech, s.bodies, s.gravity, drivers={
            "J2.theta": SmoothStep(0.0, 1.0, q0[0], q0[0] + 0.4)})
    return s, q0


def _reference(system, part, q_I, qd_I, t, q_guess) -> ReducedState:
    """The reduced state in numpy: close the loops by the damped position analysis, q' =
    B q'_I + B_p (driver rates), c from J q'' = gamma, (B^T M B) q''_I = B^T (rhs - M c)."""
    mech = system.mechanism
    values, rates, accels = driver_state(part, t)
    I, P, dep, rows = part.independent, part.driven, part.kin.dependent, part.kin.rows
    q = np.array(q_guess, dtype=float)
    q[I], q[P] = q_I, values
    q, cv, _ = solve_position(mech, q, part.kin, tol=1e-12)
    both = velocity_map(cv.J, part.kin, np.concatenate([I, P]), mech.n)
    B, Bp = both[:, :I.size], both[:, I.size:]
    qd = B @ qd_I + Bp @ rates
    c = np.zeros(mech.n)
    c[P] = accels
    cg = closure_rates(mech, cv, q, qd)
    R = cv.J[rows]
    c[dep] = np.linalg.solve(R[:, dep], cg.gamma[rows] - R @ c)
    terms = equation_terms(system, q, qd, t, tree=cg.tree)
    M, rhs = terms.M, terms.rhs
    qdd_I = np.linalg.solve(B.T @ M @ B, B.T @ (rhs - M @ c))
    qdd = B @ qdd_I + c
    return ReducedState(q, qd, qdd, qdd_I, B, terms, Bp.T @ (M @ qdd - rhs), cv.r, Bp, cv.J)


def _assert_same(a, b):
    for name in FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape, name
        if y.size:
            assert np.abs(x - y).max() <= 1e-9 * max(1.0, np.abs(y).max()), name
    assert np.abs(a.residual).max() < 1e-12 and np.abs(b.residual).max() < 1e-12


@pytest.mark.parametrize("driven", [False, True])
def test_fused_state_equals_the_reference_path(monkeypatch, driven):
    s, q0 = _system(driven)
    part = partition_system(s, q0)
    I = part.independent
    assert part.has_loops and part.kin.dependent.size
    rng = np.random.default_rng(7)
    for t in (0.0, 0.37, 0.81):
        qI = q0[I] + 0.02 * rng.standard_normal(I.size)
        qdI = rng.standard_normal(I.size)
        fast = reduced_state(s, part, qI, qdI, t, q0)
        ref = _reference(s, part, qI, qdI, t, q0)
        _assert_same(fast, ref)
        if driven:  # the driven coordinate follows its driver
            d = s.drivers["J2.theta"]
            assert fast.q[0] == d.value(t) and fast.qd[0] == pytest.approx(d.rate(t))


def test_far_start_falls_back_to_the_damped_position_analysis(monkeypatch):
    """A guess whose dependent coordinates are far off and a compiled Newton allowed a single
    iteration: it gives up, the damped position analysis closes the loops, and the same
    compiled pass from there produces the state."""
    s, q0 = _system(True)
    part = partition_system(s, q0)
    I, dep = part.independent, part.kin.dependent
    calls = []
    real = partition._closed_state

    def spy(*args, **kw):
        out = real(*args, max_iter=1)
        calls.append(out is None)
        return out

    monkeypatch.setattr(partition, "_closed_state", spy)
    guess = q0.copy()
    guess[dep] += 0.9  # rad
    fast = reduced_state(s, part, q0[I], np.zeros(I.size), 0.2, guess)
    assert calls == [True, False]  # gave up from the guess; done from the closed state
    ref = _reference(s, part, q0[I], np.zeros(I.size), 0.2, guess)
    _assert_same(fast, ref)
