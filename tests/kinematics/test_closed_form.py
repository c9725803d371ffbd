"""The closed-form references are themselves proven: loops close, and their
velocities/accelerations equal sympy derivatives of the closed-form positions."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from closed_form import (
    four_bar,
    four_bar_residual,
    is_grashof,
    slider_crank,
    slider_crank_residual,
)

W, AL = 3.7, -2.3  # crank rate (rad/s) and angular acceleration (rad/s^2)
t_sym, th0_sym = sp.symbols("t theta0", real=True)
THETA_T = th0_sym + W * t_sym + AL * t_sym**2 / 2  # theta(t): theta(0)=th0, rate W, accel AL

SLIDER_CASES = [(0.05, 0.20, 0.0), (0.05, 0.20, 0.03), (0.1, 0.25, -0.06)]  # r, l, e (m)
FOUR_BAR = dict(a=0.04, b=0.12, c=0.09, d=0.10)  # Grashof crank-rocker (m)


def _derivs_at_t0(expr):
    """Lambdified value, d/dt and d²/dt² of expr(t; theta0) at t = 0, as functions of theta0."""
    out = []
    for k in range(3):
        dk = sp.diff(expr, t_sym, k).subs(t_sym, 0)
        out.append(sp.lambdify(th0_sym, dk, "numpy"))
    return out


def _slider_dead_centres(r, l, e):
    """Crank angles where crank and rod are collinear (slider velocity 0)."""
    return np.array([np.arcsin(e / (l + r)), np.pi + np.arcsin(e / (l - r))])


@pytest.mark.parametrize("r, l, e", SLIDER_CASES)
def test_slider_crank_loop_closes_and_matches_sympy(r, l, e):
    dc = _slider_dead_centres(r, l, e)
    th = np.sort(np.concatenate([np.linspace(0, 2 * np.pi, 361), dc, dc + 1e-7]))
    st = slider_crank(th, W, AL, r, l, e)
    assert np.abs(slider_crank_residual(th, st, r, l, e)).max() < 1e-12

    phi_t = sp.asin((e - r * sp.sin(THETA_T)) / l)
    x_t = r * sp.cos(THETA_T) + l * sp.cos(phi_t)
    for expr, ours in ((phi_t, (st.phi, st.phi_d, st.phi_dd)), (x_t, (st.x, st.x_d, st.x_dd))):
        for f, mine in zip(_derivs_at_t0(expr), ours):
            ref = np.broadcast_to(f(th), th.shape)
            np.testing.assert_allclose(mine, ref, rtol=0, atol=1e-12 * max(1.0, np.abs(ref).max()))


@pytest.mark.parametrize("r, l, e", SLIDER_CASES)
def test_slider_velocity_vanishes_at_dead_centres(r, l, e):
    dc = _slider_dead_centres(r, l, e)
    st = slider_crank(dc, W, 0.0, r, l, e)
    np.testing.assert_allclose(st.x_d, 0.0, atol=1e-14)
    np.testing.assert_allclose(np.hypot(st.x, e), [l + r, l - r], rtol=0, atol=1e-14)


def test_slider_crank_left_branch_closes():
    th = np.linspace(0, 2 * np.pi, 73)
    st = slider_crank(th, W, AL, 0.05, 0.2, 0.02, branch=-1)
    assert np.all(st.x < 0)
    assert np.abs(slider_crank_residual(th, st, 0.05, 0.2, 0.02)).max() < 1e-12


@pytest.mark.parametrize("branch", ["open", "crossed"])
def test_four_bar_loop_closes_and_matches_sympy(branch):
    a, b, c, d = FOUR_BAR.values()
    assert is_grashof(a, b, c, d) and min(a, b, c, d) == a  # crank-rocker
    th = np.linspace(0, 2 * np.pi, 721)
    st = four_bar(th, W, AL, a, b, c, d, branch)
    assert np.abs(four_bar_residual(th, st, a, b, c, d)).max() < 1e-12
    # branch definition: sign of (O4 - A) x (B - A)
    A = np.stack([a * np.cos(th), a * np.sin(th)])
    B = A + b * np.stack([np.cos(st.theta3), np.sin(st.theta3)])
    cross = (d - A[0]) * (B[1] - A[1]) - (-A[1]) * (B[0] - A[0])
    assert np.all(cross > 0) if branch == "open" else np.all(cross < 0)

    sgn = 1 if branch == "open" else -1
    ax, ay = a * sp.cos(THETA_T), a * sp.sin(THETA_T)
    f2 = (d - ax) ** 2 + ay**2
    th3 = sp.atan2(-ay, d - ax) + sgn * sp.acos((b**2 + f2 - c**2) / (2 * b * sp.sqrt(f2)))
    th4 = sp.atan2(ay + b * sp.sin(th3), ax + b * sp.cos(th3) - d)
    for expr, ours in ((th3, (st.theta3, st.theta3_d, st.theta3_dd)),
                       (th4, (st.theta4, st.theta4_d, st.theta4_dd))):
        fs = _derivs_at_t0(expr)
        ang = np.angle(np.exp(1j * (ours[0] - fs[0](th))))  # angles equal modulo 2 pi
        assert np.abs(ang).max() < 1e-12
        for f, mine in zip(fs[1:], ours[1:]):
            ref = f(th)
            np.testing.assert_allclose(mine, ref, rtol=0, atol=1e-11 * np.abs(ref).max())


def test_four_bar_rocker_rate_zero_at_rocker_extremes():
    """Rocker extremes: crank and coupler collinear, |O4 - B|=c with |B| = b +- a."""
    a, b, c, d = FOUR_BAR.values()
    for L in (b + a, b - a):  # extended / folded crank-coupler
        # angle of B from the origin (law of cosines in triangle O2-O4-B), B above ground
        beta = np.arccos((L**2 + d**2 - c**2) / (2 * L * d))
        th2 = beta if L == b + a else beta + np.pi
        st = four_bar(th2, W, 0.0, a, b, c, d, "open")
        assert abs(st.theta4_d) < 1e-13


def test_four_bar_finite_differences_in_time():
    """Integrate theta2(t) with W, AL and difference the positions (independent of sympy)."""
    a, b, c, d = FOUR_BAR.values()
    t = np.linspace(0.0, 1.7, 23)
    h = 1e-5
    def th(tt):
        return 0.3 + W * tt + AL * tt**2 / 2
    def pos(tt):
        return four_bar(th(tt), 0.0, 0.0, a, b, c, d).theta4
    st = four_bar(th(t), W + AL * t, AL, a, b, c, d)
    fd1 = (pos(t + h) - pos(t - h)) / (2 * h)
    fd2 = (pos(t + h) - 2 * pos(t) + pos(t - h)) / h**2
    np.testing.assert_allclose(st.theta4_d, fd1, atol=1e-8)
    np.testing.assert_allclose(st.theta4_dd, fd2, atol=2e-4)


def test_non_assembling_inputs_raise():
    with pytest.raises(ValueError, match="cannot assemble"):
        slider_crank(np.pi / 2, 0, 0, r=0.3, l=0.2, e=0.0)
    with pytest.raises(ValueError, match="cannot assemble"):
        four_bar(np.linspace(0, 6, 20), 0, 0, a=0.2, b=0.05, c=0.05, d=0.1)
    assert not is_grashof(0.2, 0.05, 0.05, 0.1)
