"""Slider-crank (in-line, offset) and a Grashof four-bar built in 3D: positions,
velocities and accelerations over a full crank revolution equal the closed forms
of ``closed_form.py`` to 1e-10, including points within 1e-7 rad of toggles."""

from __future__ import annotations

import numpy as np
import pytest
from closed_form import four_bar, slider_crank
from kin_models import four_bar as four_bar_model
from kin_models import slider_crank as slider_crank_model
from scipy.optimize import brentq

from pipeline.kinematics import sweep

W, AL = 3.7, 0.8  # crank rate (rad/s) and angular acceleration (rad/s^2)


class CrankDriver:
    """theta(t) = theta0 + W t + AL t^2 / 2 (independent of the drivers module)."""

    def __init__(self, theta0):
        self.theta0 = theta0

    def value(self, t):
        return self.theta0 + W * t + 0.5 * AL * t * t

    def rate(self, t):
        return W + AL * t

    def accel(self, t):
        return AL

    def time_of(self, theta):
        return (-W + np.sqrt(W * W + 2.0 * AL * (theta - self.theta0))) / AL


def _times(drv, theta0, special):
    """A full revolution (181 points) plus points within 1e-7 rad of each special angle."""
    th = list(np.linspace(theta0, theta0 + 2 * np.pi, 181))
    for s in special:
        s = theta0 + np.mod(s - theta0, 2 * np.pi)
        th += [s - 1e-7, s, s + 1e-7]
    return drv.time_of(np.unique(np.clip(th, theta0, theta0 + 2 * np.pi)))


def _wrap(a):
    return np.angle(np.exp(1j * a))


def _check(name, got, ref, tol=1e-10, angle=False):
    err = np.abs(_wrap(got - ref) if angle else got - ref)
    bound = tol * max(1.0, np.abs(ref).max())
    assert err.max() <= bound, f"{name}: max error {err.max():.3e} > {bound:.1e}"
    return err.max()


@pytest.mark.parametrize("r, l, e", [(0.05, 0.20, 0.0), (0.05, 0.20, 0.03), (0.1, 0.25, -0.06)])
def test_slider_crank_equals_closed_form(r, l, e):
    theta0 = 0.3
    drv = CrankDriver(theta0)
    dead = [np.arcsin(e / (l + r)), np.pi + np.arcsin(e / (l - r))]  # crank-rod collinear
    t = _times(drv, theta0, dead)
    res = sweep(slider_crank_model(r, l, e, theta0), {"crank.theta": drv}, t)
    assert res.success, res.message
    th = drv.value(t)
    ref = slider_crank(th, drv.rate(t), AL, r, l, e)
    q, qd, qdd = res.q, res.qd, res.qdd  # crank.theta, slide.d, pin.theta, wrist.theta
    _check("x", q[:, 1], ref.x)
    _check("phi", q[:, 0] + q[:, 2], ref.phi, angle=True)
    _check("phi via wrist", -q[:, 3], ref.phi, angle=True)
    _check("x_d", qd[:, 1], ref.x_d)
    _check("phi_d", qd[:, 0] + qd[:, 2], ref.phi_d)
    _check("x_dd", qdd[:, 1], ref.x_dd)
    _check("phi_dd", qdd[:, 0] + qdd[:, 2], ref.phi_dd)
    # the sweep really passed the dead centres: slider velocity changes sign there
    assert np.min(np.abs(ref.x_d)) < 1e-6 * r * W


def _four_bar_toggles(a, b, c, d):
    """Crank angles where crank and coupler are collinear (rocker at its extremes)."""
    f = lambda x: np.sin(four_bar(x, 1.0, 0.0, a, b, c, d).theta3 - x)
    grid = np.linspace(0, 2 * np.pi, 721)
    vals = f(grid)
    return [brentq(f, grid[i], grid[i + 1], xtol=1e-15)
            for i in np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))]


def test_grashof_four_bar_equals_closed_form():
    a, b, c, d = 0.04, 0.12, 0.09, 0.10
    theta0 = 0.4
    ref0 = four_bar(theta0, 0.0, 0.0, a, b, c, d)
    drv = CrankDriver(theta0)
    toggles = _four_bar_toggles(a, b, c, d)
    assert len(toggles) == 2
    t = _times(drv, theta0, toggles)
    mech = four_bar_model(a, b, c, d, theta0, float(ref0.theta3) + 0.1, float(ref0.theta4) - 0.1)
    res = sweep(mech, {"J2.theta": drv}, t)
    assert res.success, res.message
    th = drv.value(t)
    ref = four_bar(th, drv.rate(t), AL, a, b, c, d, branch="open")
    q, qd, qdd = res.q, res.qd, res.qdd  # J2 = th2, J3 = th3 - th2, J4 = th4 - th3, J1 = th4
    _check("theta3", q[:, 0] + q[:, 1], ref.theta3, angle=True)
    _check("theta4", q[:, 3], ref.theta4, angle=True)
    _check("loop J4", q[:, 0] + q[:, 1] + q[:, 2], ref.theta4, angle=True)
    _check("theta3_d", qd[:, 0] + qd[:, 1], ref.theta3_d)
    _check("theta4_d", qd[:, 3], ref.theta4_d)
    _check("theta3_dd", qdd[:, 0] + qdd[:, 1], ref.theta3_dd)
    _check("theta4_dd", qdd[:, 3], ref.theta4_dd)
    assert np.min(np.abs(ref.theta4_d)) < 1e-6
