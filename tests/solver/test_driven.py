"""Prescribed-motion drivers in the dynamics: driver torque vs closed form, energy
balance with the driver work, a fully driven closed loop (no free coordinate)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))
from eom_models import flexible_double_pendulum
from kin_models import slider_crank

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, assemble, build_mechanism, rigid_link
from pipeline.kinematics.drivers import SmoothStep
from pipeline.solver import simulate


def _balance(r):
    E = r.energies["total"]
    scale = max(np.abs(r.energies["kinetic"]).max(), np.abs(r.energies["driver_work"]).max())
    return float(np.abs(E - E[0]).max() / scale)


def test_driven_pendulum_torque_matches_closed_form():
    m, l, g = 1.7, 0.8, 9.81
    mech = build_mechanism([rigid_link("ground"), rigid_link("arm")],
                           [Joint("pin", "revolute", "ground", "body", "arm", "body")])
    s = System(mech, {"arm": BodyMass.rigid(m, [l, 0, 0], np.zeros((3, 3)))},
               gravity=[0.0, -g, 0.0], drivers={"pin.theta": SmoothStep(0.0, 1.0, 0.0, 2.0)})
    te = np.linspace(0, 1.2, 25)
    r = simulate(s, np.zeros(1), np.zeros(1), (0, 1.2), te, progress=False)
    assert r.success, r.message
    assert r.driven == ("pin.theta",)
    d = s.drivers["pin.theta"]
    th, thdd = d.value(te), d.accel(te)
    ref = m * l * l * thdd + m * g * l * np.cos(th)
    assert np.allclose(r.q[:, 0], th, rtol=0, atol=1e-14)
    assert np.abs(r.driver_forces[:, 0] - ref).max() < 1e-10 * np.abs(ref).max()
    assert _balance(r) < 1e-7


def test_driven_flexible_pendulum_energy_balance_with_driver_work():
    base = flexible_double_pendulum(n_modes=2).system
    s = System(base.mechanism, base.bodies, base.gravity,
               drivers={"j1.theta": SmoothStep(0.0, 0.8, 0.0, -1.0)})
    q0 = np.zeros(s.mechanism.n)
    r = simulate(s, q0, q0, (0, 1.0), np.linspace(0, 1, 51), rtol=1e-10, atol=1e-10,
                 progress=False)
    assert r.success, r.message
    assert np.abs(r.energies["driver_work"]).max() > 0.1 * np.abs(r.energies["kinetic"]).max()
    assert _balance(r) < 1e-6


def test_fully_driven_slider_crank_needs_no_integration_state():
    mech = slider_crank(0.3, 1.0, 0.1, 0.3)
    s = System(mech, {"crank": BodyMass.rigid(4.0, [0.02, 0, 0], np.diag([.3, .3, .8])),
                      "rod": BodyMass.rigid(1.5, [0.4, 0, 0], np.diag([.01, .1, .12])),
                      "slider": BodyMass.rigid(2.5, [0, 0, 0], np.eye(3) * 0.01)},
               gravity=[0.0, -9.81, 0.0],
               drivers={"crank.theta": SmoothStep(0.0, 1.0, 0.3, 3.0)})
    q0 = assemble(mech, driven=["crank.theta"]).q
    r = simulate(s, q0, np.zeros(mech.n), (0, 1.2), np.linspace(0, 1.2, 25), progress=False)
    assert r.success, r.message
    assert r.closure_residual.max() < 1e-10
    assert _balance(r) < 1e-7  # the crank torque's work equals T + V
