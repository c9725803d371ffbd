"""Generalised-alpha: coefficients, second-order convergence against DOP853 at tight
tolerance, numerical damping of a mode far above 1/h as the spectral radius says, closed
loops kept closed, partial history when Newton cannot converge."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
from eom_models import flexible_double_pendulum, flexible_four_bar

from pipeline.core.errors import ConfigError
from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.forces import JointSpringDamper
from pipeline.kinematics import Joint, assemble, build_mechanism, rigid_link
from pipeline.solver import simulate
from pipeline.solver.generalized_alpha import coefficients


def test_coefficients_match_chung_hulbert():
    for rho in (0.0, 0.5, 0.8, 1.0):
        am, af, beta, gamma = coefficients(rho)
        assert am == pytest.approx((2 * rho - 1) / (rho + 1))
        assert af == pytest.approx(rho / (rho + 1))
        assert gamma == pytest.approx(0.5 - am + af)  # second order
        assert beta == pytest.approx((1 - am + af) ** 2 / 4)
    with pytest.raises(ConfigError, match="rho_inf"):
        coefficients(1.5)


@pytest.mark.parametrize("rho", [1.0, 0.8])
def test_second_order_convergence_flexible_double_pendulum(rho):
    s = flexible_double_pendulum(n_modes=2).system
    q0 = np.zeros(s.mechanism.n)
    te = np.linspace(0, 0.3, 4)
    ref = simulate(s, q0, q0, (0, 0.3), te, rtol=1e-11, atol=1e-11, progress=False)
    errs = []
    for h in (2e-3, 1e-3):
        r = simulate(s, q0, q0, (0, 0.3), te, method="generalized_alpha", step=h,
                     rho_inf=rho, rtol=1e-10, atol=1e-12, progress=False)
        assert r.success, r.message
        errs.append(np.abs(r.q - ref.q).max())
    assert 3.0 < errs[0] / errs[1] < 5.0, errs
    assert errs[1] < 1e-4


def _stiff_pendulum(k=1e6, inertia=1.0):
    mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
                           [Joint("pin", "revolute", "ground", "body", "arm", "body")])
    body = BodyMass.rigid(1.0, [0.0, 0.0, 0.0], np.diag([inertia, inertia, inertia]))
    return System(mech, {"arm": body}, [0.0, 0.0, 0.0],
                  forces=[JointSpringDamper("spring", "pin.theta", stiffness=k)])


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
@pytest.mark.parametrize("rho", [0.0, 0.5, 1.0])
def test_mode_far_above_the_step_is_damped_by_rho_inf(rho, formulation):
    """w h = 100: the amplification's eigenvalues are ~ -rho_inf (a double root), so the
    amplitude after n steps is O(n rho^n); rho = 1 keeps it (no numerical damping). Every
    step has the user's size: an open chain has no branch whose continuity would shorten
    a step that moves a stiff mode far from its prediction."""
    s = _stiff_pendulum()  # w = 1000 rad/s
    h, n = 0.1, 40
    te = np.linspace(0, n * h, n + 1)
    r = simulate(s, np.array([0.01]), np.zeros(1), (0, n * h), te, method="generalized_alpha",
                 step=h, rho_inf=rho, progress=False, formulation=formulation)
    assert r.success, r.message
    assert r.n_steps == n
    late = np.abs(r.q[-10:, 0]).max()
    if rho == 1.0:  # undamped: the (aliased) oscillation keeps its amplitude
        assert 0.8e-2 < np.abs(r.q[10:, 0]).max() <= 1.0001e-2
    else:
        assert late <= 0.01 * 4 * n * rho ** (n - 10) + 1e-15


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
def test_closed_loop_stays_closed_and_matches_dop853(formulation):
    s = flexible_four_bar().system
    q0 = assemble(s.mechanism, s.mechanism.q_initial).q
    qd0 = np.zeros_like(q0)
    te = np.linspace(0, 0.5, 6)
    ref = simulate(s, q0, qd0, (0, 0.5), te, rtol=1e-10, atol=1e-10, progress=False,
                   formulation="partitioned")
    r = simulate(s, q0, qd0, (0, 0.5), te, method="generalized_alpha", step=1e-3,
                 rho_inf=0.9, progress=False, formulation=formulation)
    assert r.formulation == formulation
    assert r.success, r.message
    assert r.closure_residual.max() < 1e-10
    assert np.abs(r.q - ref.q).max() < 1e-3


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
def test_needs_a_step_and_reports_newton_failure(formulation):
    s = flexible_double_pendulum(n_modes=1).system
    q0 = np.zeros(s.mechanism.n)
    if formulation == "partitioned":  # the DAE formulation adapts the step without one
        with pytest.raises(ConfigError, match="step"):
            simulate(s, q0, q0, (0, 1), method="generalized_alpha", progress=False,
                     formulation=formulation)

    class NaNAfter:
        name, conservative = "nan", False

        def generalized_force(self, system, tree, q, qd, t):
            return np.full(q.shape, np.nan) if t > 0.2 else np.zeros_like(q)

        def potential_energy(self, system, tree, q):
            return 0.0

    bad = System(s.mechanism, s.bodies, s.gravity, forces=(NaNAfter(),))
    r = simulate(bad, q0, q0, (0, 1), np.linspace(0, 1, 11), method="generalized_alpha",
                 step=0.01, progress=False, formulation=formulation)
    assert not r.success and r.verdict == "partial"
    assert ("Newton failed" if formulation == "partitioned" else "could not be evaluated") \
        in r.message
    assert 0 < r.t.size < 11 and r.t[-1] <= 0.2 and np.all(np.isfinite(r.q))
