"""A four-bar whose coupler is flexible (hand-made phi/psi at its distal pin).

Independent prediction: with in-plane modes the deformed coupler is a rigid
coupler whose distal pin sits at (b + u_x, u_y) in its body frame, i.e. a
four-bar with coupler length b' = |(b + u_x, u_y)| whose line A->B' makes the
angle delta = atan2(u_y, b + u_x) with the body x axis. The distal frame is
turned by (1 + [theta]x) = sqrt(1 + theta_z^2) rot_z(atan(theta_z)), so the
closed four-bar (closed_form.four_bar with b') gives every joint variable:
J3 = theta3' - delta - theta2, J4 = theta4 - (theta3' - delta + atan theta_z),
J1 = theta4.
"""

from __future__ import annotations

import numpy as np
import pytest
from closed_form import four_bar
from kin_models import four_bar as four_bar_model

from pipeline.kinematics import assemble, closure_residual, sweep

A, B, C, D = 0.04, 0.12, 0.09, 0.10
PHI = np.array([[0.0, 0.02, 0.0], [0.004, 0.0, 0.0]])  # m per unit eta (bending, axial)
PSI = np.array([[0.0, 0.0, 0.3], [0.0, 0.0, 0.0]])  # rad per unit eta (about z)


def _predict(theta2, eta):
    u, th = eta @ PHI, (eta @ PSI)[2]
    b_eff, delta = np.hypot(B + u[0], u[1]), np.arctan2(u[1], B + u[0])
    fb = four_bar(theta2, 0.0, 0.0, A, b_eff, C, D, branch="open")
    beta = fb.theta3 - delta  # coupler body angle
    return np.array([beta - theta2, fb.theta4 - beta - np.arctan(th), fb.theta4])


def _wrap(a):
    return np.angle(np.exp(1j * a))


@pytest.fixture(scope="module")
def mech():
    return four_bar_model(A, B, C, D, 0.4, 0.6, 1.2, flexible=(PHI, PSI))


@pytest.mark.parametrize("theta2", [0.4, 1.9, 3.5, 5.2])
@pytest.mark.parametrize("eta", [(0.3, -0.5), (-1.0, 2.0)])
def test_closure_and_dependent_joints_with_prescribed_modes(mech, theta2, eta):
    eta = np.array(eta)
    q = mech.q_initial.copy()
    q[mech.index("J2.theta")] = theta2
    q[mech.indices(["coupler.eta1", "coupler.eta2"])] = eta
    rigid = _predict(theta2, np.zeros(2))  # start from the undeformed assembly
    q[mech.indices(["J3.theta", "J4.theta", "J1.theta"])] = rigid
    a = assemble(mech, q, driven=["J2.theta"])
    assert np.abs(closure_residual(mech, a.q)).max() <= 1e-12
    got = a.q[mech.indices(["J3.theta", "J4.theta", "J1.theta"])]
    want = _predict(theta2, eta)
    assert np.abs(_wrap(got - want)).max() < 1e-10
    # the deflection really moved the dependent joints (not a vacuous match)
    assert np.abs(_wrap(want - rigid)).max() > 1e-3
    assert np.array_equal(a.q[mech.indices(["coupler.eta1", "coupler.eta2"])], eta)


class Harmonic:
    def __init__(self, amp, w, offset=0.0):
        self.amp, self.w, self.offset = amp, w, offset

    def __add__(self, c):
        return Harmonic(self.amp, self.w, self.offset + c)

    def value(self, t):
        return self.offset + self.amp * np.sin(self.w * t)

    def rate(self, t):
        return self.amp * self.w * np.cos(self.w * t)

    def accel(self, t):
        return -self.amp * self.w**2 * np.sin(self.w * t)


def test_modal_motion_drives_the_dependent_joints(mech):
    """Crank held, eta1 oscillating: positions equal the prediction, rates equal
    its chain-rule derivative (central differences in eta)."""
    theta2 = 1.0
    q = mech.q_initial.copy()
    q[mech.index("J2.theta")] = theta2
    q[mech.indices(["J3.theta", "J4.theta", "J1.theta"])] = _predict(theta2, np.zeros(2))
    drv = {"J2.theta": Harmonic(0.0, 1.0) + theta2, "coupler.eta1": Harmonic(1.5, 2.0)}
    t = np.linspace(0.0, 3.0, 61)
    res = sweep(mech, drv, t, q)
    assert res.success, res.message
    idx = mech.indices(["J3.theta", "J4.theta", "J1.theta"])
    h = 1e-6
    for k, tk in enumerate(t):
        eta = np.array([drv["coupler.eta1"].value(tk), 0.0])
        assert np.abs(_wrap(res.q[k, idx] - _predict(theta2, eta))).max() < 1e-10
        d_eta = (_predict(theta2, eta + [h, 0]) - _predict(theta2, eta - [h, 0])) / (2 * h)
        assert np.abs(res.qd[k, idx] - d_eta * drv["coupler.eta1"].rate(tk)).max() < 1e-7
