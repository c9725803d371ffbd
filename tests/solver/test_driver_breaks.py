"""Drivers whose rate or acceleration jumps (a linear table's knots, a ramp's start, a
pchip table's knots): a transient run ends a step on each break and starts afresh there,
with the impulse an ideal prescribed motion needs where its rate jumps.

Reference: a pendulum hung from a cart whose position is a piecewise-linear table, in
its one minimal coordinate, integrated by scipy between the knots at 1e-12; at each knot
the angular momentum about the cart's pivot is kept, so the rate jumps by
sin(theta) dv / l (the cart's rate jump dv). Written by hand, independent of the
package's equations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.driver_table import Table
from pipeline.solver import simulate

M, L, G = 1.3, 0.7, 9.81
KNOTS = np.array([0.0, 0.3037, 0.6071, 1.0013])  # off any step grid
STROKE = np.array([0.0, 0.12, -0.05, 0.02])
T_END, TH0 = 1.2, -np.pi / 2 + 0.4


def _ry(a):
    T = np.eye(4)
    T[0, 0] = T[2, 2] = np.cos(a)
    T[0, 2], T[2, 0] = np.sin(a), -np.sin(a)
    return T


def _cart_pendulum(interpolation="linear"):
    """The cart slides along world x (a prismatic joint on a frame turned so that its z is
    x), the arm (a point mass M at L) turns about world z; gravity along -y. The arm's
    angle theta is measured from x: the bob is at (x + L cos theta, L sin theta)."""
    mech = build_mechanism(
        [rigid_link("ground", {"rail": _ry(np.pi / 2)}),
         rigid_link("cart", {"pivot": _ry(-np.pi / 2)}), rigid_link("arm")],
        [Joint("slide", "prismatic", "ground", "rail", "cart", "body"),
         Joint("pin", "revolute", "cart", "pivot", "arm", "body")])
    return System(mech, {"cart": BodyMass.rigid(1.0, [0, 0, 0], 0.01 * np.eye(3)),
                         "arm": BodyMass.rigid(M, [L, 0, 0], np.zeros((3, 3)))},
                  gravity=[0, -G, 0],
                  drivers={"slide.d": Table(KNOTS, STROKE, interpolation)})


def _reference() -> float:
    """theta at T_END: theta'' = (sin(theta) x'' - g cos(theta)) / l, x'' = 0 between the
    knots; the momentum l^2 theta' - l sin(theta) x' is kept across each."""
    slopes = np.append(np.diff(STROKE) / np.diff(KNOTS), 0.0)
    y, t = np.array([TH0, 0.0]), 0.0  # the arm starts at rest
    for k, edge in enumerate(list(KNOTS[1:]) + [T_END]):
        sol = solve_ivp(lambda _t, y: [y[1], -G * np.cos(y[0]) / L], (t, edge), y,
                        method="DOP853", rtol=1e-12, atol=1e-13)
        y, t = sol.y[:, -1].copy(), edge
        if k + 1 < KNOTS.size:
            y[1] += np.sin(y[0]) * (slopes[k + 1] - slopes[k]) / L
    return float(y[0])


def _run(system, **kw):
    return simulate(system, np.array([0.0, TH0]), np.zeros(2), (0.0, T_END),
                    np.linspace(0.0, T_END, 13), progress=False, **kw)


def test_the_breaks_of_the_drivers():
    lin, spline = Table(KNOTS, STROKE), Table(KNOTS, STROKE, "spline")
    assert lin.breaks() == tuple(KNOTS) and spline.breaks() == (KNOTS[0], KNOTS[-1])
    assert (lin + spline).breaks() == tuple(KNOTS)


def test_a_rate_jump_gives_the_impulse_and_fixed_steps_keep_second_order():
    """Generalised-alpha at 4, 2 and 1 ms: errors fall 4x per halving (they did not fall
    at all before: without the impulse the run tended to another motion, 0.25 rad off,
    that the energy check alone flagged), and the energy balance holds with the
    impulses' work (the kinetic energy they add)."""
    system, ref = _cart_pendulum(), _reference()
    errors = []
    for h in (4e-3, 2e-3, 1e-3):
        r = _run(system, method="generalized_alpha", step=h, rtol=1e-4, atol=1e-7)
        assert r.success and not any("energy" in w for w in r.warnings), r.warnings
        errors.append(abs(r.q[-1, 1] - ref))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(rates > 1.8), (errors, rates)
    assert errors[-1] < 2e-6
    E = r.energies
    assert abs(E["driver_work"][-1]) > 0.05  # the impulses did work the balance counts
    assert np.abs(E["total"] - E["total"][0]).max() < 1e-3 * np.abs(E["kinetic"]).max()


@pytest.mark.parametrize("method", ["generalized_alpha", "Radau", "DOP853"])
def test_every_method_takes_the_impulse(method):
    """Adaptive generalised-alpha (the DAE's steps), scipy's implicit and explicit
    methods (the partitioned coordinates): each stops at the knots and gives the
    reference at its tolerance."""
    r = _run(_cart_pendulum(), method=method, rtol=1e-9, atol=1e-11)
    assert r.verdict == "ok", r.warnings
    tol = 1e-5 if method == "generalized_alpha" else 1e-7
    assert abs(r.q[-1, 1] - _reference()) < tol


def test_an_acceleration_jump_keeps_second_order():
    """A pchip table (C1: its acceleration jumps at the knots, no impulse): against the
    same run at 1/16 of the step, the errors at 4, 2 and 1 ms fall 4x per halving."""
    system = _cart_pendulum("pchip")
    fine = _run(system, method="generalized_alpha", step=1e-3 / 16, rtol=1e-4, atol=1e-7,
                error_estimate=False)
    errors = [abs(_run(system, method="generalized_alpha", step=h, rtol=1e-4, atol=1e-7,
                       error_estimate=False).q[-1, 1] - fine.q[-1, 1])
              for h in (4e-3, 2e-3, 1e-3)]
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(rates > 1.8), (errors, rates)
