"""Lagrange check: M q'' + h equals d/dt dT/dq' - dT/dq of an independently coded T.

T = 1/2 sum_g m_g |R_g'|^2 over the point clouds, with hand-coded kinematics
(eom_models) and complex-step velocities; derivatives by finite differences.
T is quadratic in q', so differences in q' are exact up to rounding; the
q-differences are central with h = 1e-5 (truncation ~1e-10 relative).
"""

from __future__ import annotations

import numpy as np
import pytest
from eom_models import flexible_double_pendulum, flexible_four_bar, kinetic, potential

from pipeline.dynamics.equations import equation_terms
from pipeline.dynamics.gravity import gravity_force, gravity_potential
from pipeline.kinematics import evaluate_tree

H = 1e-5


def _T(model, q, qd):
    return kinetic(model.positions, model.masses, q, qd)


def _p(model, q, qd):
    """dT/dq' (exact: T quadratic in q')."""
    n = q.size
    return np.array([(_T(model, q, qd + e) - _T(model, q, qd - e)) / 2.0 for e in np.eye(n)])


def lagrange_fd(model, q, qd, qdd):
    """d/dt dT/dq' - dT/dq by finite differences of the hand-coded T."""
    n = q.size
    dp_dq = (_p(model, q + H * qd, qd) - _p(model, q - H * qd, qd)) / (2 * H)
    dp_dqd = _p(model, q, qd + qdd) - _p(model, q, qd)
    dT_dq = np.array([(_T(model, q + H * e, qd) - _T(model, q - H * e, qd)) / (2 * H)
                      for e in np.eye(n)])
    return dp_dq + dp_dqd - dT_dq


def _random_state(rng, model):
    mech = model.system.mechanism
    q = rng.uniform(-np.pi, np.pi, mech.n)
    q[mech.modal_coordinates] = 0.5 * rng.standard_normal(mech.modal_coordinates.size)
    return q, rng.standard_normal(mech.n) * 2.0, rng.standard_normal(mech.n) * 5.0


MODELS = {"double_pendulum": flexible_double_pendulum, "four_bar": flexible_four_bar,
          # links whose mass moves towards their reference as they bend (second-order first
          # moment, geometric stiffening by accelerations and gravity)
          "double_pendulum_second_order": lambda: flexible_double_pendulum(second_order=True)}


@pytest.mark.parametrize("name", sorted(MODELS))
def test_lagrange_equations_match_fd_of_kinetic_energy(name):
    model = MODELS[name]()
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(4):
        q, qd, qdd = _random_state(rng, model)
        terms = equation_terms(model.system, q, qd, 0.0)
        ours = terms.M @ qdd + terms.h
        ref = lagrange_fd(model, q, qd, qdd)
        worst = max(worst, np.abs(ours - ref).max() / np.abs(ref).max())
    assert worst < 1e-6, worst


@pytest.mark.parametrize("name", sorted(MODELS))
def test_mass_matrix_is_hessian_of_kinetic_energy(name):
    model = MODELS[name]()
    rng = np.random.default_rng(3)
    q, _, _ = _random_state(rng, model)
    n = q.size
    E = np.eye(n)
    T = lambda v: _T(model, q, v)
    Hs = np.array([[T(E[i] + E[j]) - T(E[i]) - T(E[j]) + T(0 * E[0]) for j in range(n)]
                   for i in range(n)])
    M = equation_terms(model.system, q, np.zeros(n), 0.0).M
    assert np.abs(M - Hs).max() <= 1e-12 * np.abs(Hs).max()
    assert np.allclose(M, M.T, rtol=0, atol=1e-14 * np.abs(M).max())


@pytest.mark.parametrize("name", sorted(MODELS))
def test_gravity_force_is_minus_gradient_of_point_potential(name):
    model = MODELS[name]()
    s = model.system
    rng = np.random.default_rng(11)
    q, _, _ = _random_state(rng, model)
    g = s.gravity
    n = q.size
    ref = -np.array([(potential(model.positions, model.gravity_masses, q + H * e, g)
                      - potential(model.positions, model.gravity_masses, q - H * e, g)) / (2 * H)
                     for e in np.eye(n)])
    tree = evaluate_tree(s.mechanism, q)
    Q = gravity_force(s, tree, q)
    assert np.abs(Q - ref).max() <= 1e-8 * np.abs(ref).max()
    V = gravity_potential(s, tree, q)
    V_ref = potential(model.positions, model.gravity_masses, q, g)
    assert abs(V - V_ref) <= 1e-12 * max(1.0, abs(V))
