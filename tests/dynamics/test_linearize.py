"""Linearised vibration vs closed forms: a rigid link on a torsional spring (with
gravity and damping), a two-DOF spring-mass chain, and a flexible beam on a
hinge with a root spring vs the Euler-Bernoulli characteristic equation."""

from __future__ import annotations

import numpy as np
import pytest
from dyn2_models import eb_cantilever, rigid_bar
from scipy.optimize import brentq

from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.forces import JointSpringDamper, SpringDamper
from pipeline.dynamics.linearize import marker_motion, vibration_modes
from pipeline.dynamics.statics import static_equilibrium
from pipeline.kinematics import Joint, build_mechanism, flexible_link, rigid_link
from pipeline.kinematics.rotations import translation

G = 9.81


def _hinged(body_link, body, k, c=0.0, gravity=(0.0, -G, 0.0)):
    mech = build_mechanism([rigid_link("ground"), body_link],
                           [Joint("pin", "revolute", "ground", "body", body_link.name, "body",
                                  (-np.pi / 2,))])
    return System(mech, {body_link.name: body}, gravity,
                  forces=[JointSpringDamper("k", "pin.theta", stiffness=k,
                                            free_value=-np.pi / 2, damping=c)])


@pytest.mark.parametrize("c", [0.0, 3.0])
def test_rigid_link_on_torsional_spring_hanging(c):
    m, length, k = 2.0, 0.8, 30.0
    system = _hinged(rigid_link("arm", {"tip": translation([length, 0, 0])}),
                     rigid_bar(m, length), k, c)
    eq = static_equilibrium(system, np.array([-np.pi / 2]))
    assert eq.success and eq.q[0] == pytest.approx(-np.pi / 2, abs=1e-12)
    modes = vibration_modes(system, eq.q)
    I_pivot = m * length**2 / 3
    wn = np.sqrt((k + m * G * length / 2) / I_pivot)  # spring + gravity pendulum stiffness
    zeta = c / (2 * np.sqrt((k + m * G * length / 2) * I_pivot))
    assert modes.omega[0] == pytest.approx(wn, rel=1e-7)
    assert modes.damping_ratios[0] == pytest.approx(zeta, rel=1e-7, abs=1e-12)
    assert modes.frequencies_hz[0] == pytest.approx(wn * np.sqrt(1 - zeta**2) / (2 * np.pi),
                                                    rel=1e-7)
    # the tip moves horizontally (perpendicular to the hanging arm) by L per rad
    motion = marker_motion(system, modes, "arm", "tip")[:, 0]
    assert np.abs(motion) == pytest.approx([length, 0.0, 0.0], abs=1e-12)


def chain(m1, m2, k1, k2, c=0.0):
    """Two masses on prismatic joints along global z, springs ground-m1 and m1-m2."""
    mech = build_mechanism([rigid_link("ground"), rigid_link("m1"), rigid_link("m2")],
                           [Joint("s1", "prismatic", "ground", "body", "m1", "body", (1.0,)),
                            Joint("s2", "prismatic", "m1", "body", "m2", "body", (0.7,))])
    bodies = {"m1": BodyMass.rigid(m1, [0, 0, 0], np.eye(3) * 0.01),
              "m2": BodyMass.rigid(m2, [0, 0, 0], np.eye(3) * 0.01)}
    forces = [SpringDamper("k1", ("ground", "body"), ("m1", "body"), stiffness=k1,
                           free_length=1.0, damping=c),
              SpringDamper("k2", ("m1", "body"), ("m2", "body"), stiffness=k2, free_length=0.7)]
    return System(mech, bodies, [0.0, 0.0, 0.0], forces=forces)


def test_two_dof_spring_mass_chain_closed_form():
    m1, m2, k1, k2 = 3.0, 1.5, 2.0e3, 800.0
    system = chain(m1, m2, k1, k2)
    modes = vibration_modes(system, system.mechanism.q_initial)
    # det([[k1 + k2 - w2 m1, -k2], [-k2, k2 - w2 m2]]) = 0: quadratic in w2
    a, b, cc = m1 * m2, -(m1 * k2 + m2 * (k1 + k2)), k1 * k2
    w2 = np.sort((-b + np.array([-1, 1]) * np.sqrt(b * b - 4 * a * cc)) / (2 * a))
    np.testing.assert_allclose(modes.omega, np.sqrt(w2), rtol=1e-8)
    # shapes in absolute displacements: u2/u1 = k2 / (k2 - w2 m2); q = (u1, u2 - u1)
    for j in range(2):
        u1, rel = modes.shapes_q[:, j]
        assert (u1 + rel) / u1 == pytest.approx(k2 / (k2 - w2[j] * m2), rel=1e-7)
    assert np.all(modes.damping_ratios == 0.0)


def test_two_dof_chain_damping_matches_state_space_reference():
    m1, m2, k1, k2, c = 3.0, 1.5, 2.0e3, 800.0, 12.0
    modes = vibration_modes(chain(m1, m2, k1, k2, c), np.array([1.0, 0.7]))
    # reference in absolute displacements u: M u'' + C u' + K u = 0
    M, K = np.diag([m1, m2]), np.array([[k1 + k2, -k2], [-k2, k2]])
    C = np.array([[c, 0.0], [0.0, 0.0]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(A)
    lam = np.sort_complex(lam[lam.imag > 0])
    np.testing.assert_allclose(np.sort(modes.omega), np.sort(np.abs(lam)), rtol=1e-8)
    np.testing.assert_allclose(np.sort(modes.damping_ratios),
                               np.sort(-lam.real / np.abs(lam)), rtol=1e-7)


def _hinged_beam_frequencies(L, EI, rho_A, k_r, n):
    """EB beam, hinge with rotational spring k_r at x = 0, free at L: roots of the 4x4 determinant
    of w = a cosh bx + b cos bx + c sinh bx + d sin bx with w(0) = 0, EI w''(0) = k_r w'(0),
    w''(L) = w'''(L) = 0."""
    def det(beta):
        bl = beta * L
        ch, c, sh, s = np.cosh(bl), np.cos(bl), np.sinh(bl), np.sin(bl)
        rows = [[1, 1, 0, 0],
                [EI * beta**2, -EI * beta**2, -k_r * beta, -k_r * beta],
                [ch, -c, sh, -s],
                [sh, s, ch, -c]]
        return np.linalg.det(np.array(rows, float)) / ch**2
    grid = np.linspace(0.05, 12.0, 4000) / L
    vals = [det(b) for b in grid]
    roots = [brentq(det, grid[i], grid[i + 1], xtol=1e-14)
             for i in range(len(grid) - 1) if np.sign(vals[i]) != np.sign(vals[i + 1])]
    return np.array(roots[:n]) ** 2 * np.sqrt(EI / rho_A)


def test_flexible_beam_on_hinge_spring_matches_euler_bernoulli():
    L, EI, rho_A, k_r = 2.0, 3.0e4, 12.0, 2.0e3
    body, phi, psi, _ = eb_cantilever(L, EI, rho_A, 6)
    beam = flexible_link("beam", {"tip": (translation([L, 0, 0]), phi, psi)})
    system = _hinged(beam, body, k_r, gravity=(0.0, 0.0, 0.0))
    q = np.zeros(system.mechanism.n)
    q[0] = -np.pi / 2
    modes = vibration_modes(system, q)
    ref = _hinged_beam_frequencies(L, EI, rho_A, k_r, 3)
    err = modes.omega[:3] / ref - 1
    print("\nhinged beam (6 clamped modes + hinge): rel. errors", np.round(err, 7))
    assert np.all(err > -1e-9)  # Rayleigh-Ritz: from above
    assert np.all(err < 1e-2)


def test_closed_loop_slider_crank_on_a_spring_closed_form():
    """Crank inertia I_c, slider mass m_s, spring k on the slider at its free length:
    omega^2 = k x'^2 / (I_c + m_s x'^2), x' = dx/dtheta of the loop (closed form)."""
    from kin_models import slider_crank

    from pipeline.kinematics import assemble

    r, l, e, I_c, m_s, k = 0.3, 1.0, 0.1, 0.02, 2.5, 3.0e3
    mech = slider_crank(r, l, e, theta0=0.9)
    q = assemble(mech).q
    x0 = q[mech.index("slide.d")]
    system = System(mech, {"crank": BodyMass.rigid(1.0, [0, 0, 0], np.diag([I_c] * 3)),
                           "slider": BodyMass.rigid(m_s, [0, 0, 0], np.eye(3) * 1e-3)},
                    [0.0, 0.0, 0.0],
                    forces=[SpringDamper("k", ("ground", "rail"), ("slider", "body"),
                                         stiffness=k, free_length=x0)])
    modes = vibration_modes(system, q)
    th = q[mech.index("crank.theta")]
    xp = -r * np.sin(th) + (e - r * np.sin(th)) * r * np.cos(th) / np.sqrt(
        l**2 - (e - r * np.sin(th)) ** 2)
    assert modes.model.coordinates == ("crank.theta",) or modes.omega.size == 1
    assert modes.omega[0] == pytest.approx(np.sqrt(k * xp**2 / (I_c + m_s * xp**2)), rel=1e-7)


def test_linearize_rejects_bad_input():
    from pipeline.core.errors import ConfigError

    system = chain(1.0, 1.0, 10.0, 10.0)
    with pytest.raises(ConfigError, match="q_eq: expected 2 finite values"):
        vibration_modes(system, np.array([1.0]))
    bad = System(system.mechanism, system.bodies, [0, 0, 0],
                 forces=[SpringDamper("x", ("m1", "nope"), ("m2", "body"), stiffness=1.0)])
    with pytest.raises(ConfigError, match="frame 'nope' does not exist"):
        vibration_modes(bad, np.array([1.0, 0.7]))
