"""Joint transforms, derivative operators and shape matrices vs finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.core.errors import ConfigError
from pipeline.kinematics import JOINTS, Joint, flexible_link, rigid_link
from pipeline.kinematics.rotations import (
    exp_so3,
    frame_from_z,
    homogeneous,
    inverse,
    log_so3,
    rot_x,
    rot_y,
    rot_z,
    skew,
    vee,
)

H = 1e-6
RNG = np.random.default_rng(7)


def _rel(a, b):
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


@pytest.mark.parametrize("name", sorted(JOINTS))
@pytest.mark.parametrize("reverse", [False, True])
def test_joint_jacobian_equals_central_differences(name, reverse):
    seq = JOINTS[name].reverse if reverse else JOINTS[name].motion
    n = JOINTS[name].n
    for _ in range(3):
        q = RNG.uniform(-1.2, 1.2, n)
        dG = seq.derivatives(q)
        for k in range(n):
            e = np.zeros(n)
            e[k] = H
            fd = (seq.transform(q + e) - seq.transform(q - e)) / (2 * H)
            assert _rel(dG[k], fd) < 1e-7, (name, k)


@pytest.mark.parametrize("name", sorted(JOINTS))
def test_operators_give_phi_q(name):
    """dPhi/dq_k = Phi Q_k; Q_k is the constant generator for the last motion
    and for every motion of revolute, prismatic and cylindrical joints."""
    jt = JOINTS[name]
    q = RNG.uniform(-1.0, 1.0, jt.n)
    Phi, dPhi, Qk = jt.motion.transform(q), jt.motion.derivatives(q), jt.motion.operators(q)
    for k in range(jt.n):
        assert np.allclose(dPhi[k], Phi @ Qk[k], atol=1e-14)
    if jt.n:
        assert np.allclose(Qk[-1], jt.motion.generators[-1])
    if name in ("revolute", "prismatic", "cylindrical"):
        assert np.allclose(Qk, jt.motion.generators)


@pytest.mark.parametrize("name", sorted(JOINTS))
def test_joint_second_derivative_term_and_inverse(name):
    """Phi'' at q'' = 0 equals the FD of Phi' along q'; the reversed sequence is Phi^-1."""
    jt = JOINTS[name]
    q, qd = RNG.uniform(-1.0, 1.0, jt.n), RNG.normal(size=jt.n)
    G, _, _, Gdd = jt.motion.evaluate(q, qd)
    fd = (jt.motion.evaluate(q + H * qd, qd)[2] - jt.motion.evaluate(q - H * qd, qd)[2]) / (2 * H)
    assert np.abs(Gdd - fd).max() <= 1e-7 * max(1.0, np.abs(Gdd).max())
    assert np.allclose(jt.reverse.transform(q) @ G, np.eye(4), atol=1e-14)


def test_joint_transforms_are_the_documented_motions():
    q = [0.3, -0.2, 0.7]
    T = homogeneous
    assert np.allclose(JOINTS["revolute"].motion.transform([0.3]), T(rot_z(0.3)))
    assert np.allclose(JOINTS["prismatic"].motion.transform([0.3]), T(None, [0, 0, 0.3]))
    assert np.allclose(JOINTS["spherical"].motion.transform(q),
                       T(rot_z(0.3) @ rot_y(-0.2) @ rot_x(0.7)))
    assert np.allclose(JOINTS["universal"].motion.transform(q[:2]), T(rot_x(0.3) @ rot_y(-0.2)))
    assert np.allclose(JOINTS["planar"].motion.transform(q), T(rot_z(0.7), [0.3, -0.2, 0]))
    assert np.allclose(JOINTS["fixed"].motion.transform([]), np.eye(4))


def test_spherical_pitch_bounded_by_rotation_angle():
    """Gimbal-lock claim of the docstring: any rotation by a <= 60 deg from the
    assembled orientation has ZYX pitch |ry| <= a (so cos ry >= 0.5)."""
    for _ in range(2000):
        axis = RNG.normal(size=3)
        a = RNG.uniform(0, np.radians(60))
        R = exp_so3(a * axis / np.linalg.norm(axis))
        ry = np.arcsin(np.clip(-R[2, 0], -1, 1))
        assert abs(ry) <= a + 1e-12


def _flex_link(m=3):
    phi, psi = RNG.normal(size=(m, 3)), RNG.normal(size=(m, 3))
    pose = homogeneous(exp_so3(RNG.normal(size=3)), RNG.normal(size=3))
    return flexible_link("beam", {"tip": (pose, phi, psi)}), pose, phi, psi


def test_flexible_shape_matrix_formula_and_derivative():
    link, S0, phi, psi = _flex_link()
    fr = link.frame("tip")
    eta = RNG.normal(size=3) * 0.1
    u, th = eta @ phi, eta @ psi
    S = fr.shape(eta)
    assert np.allclose(S[:3, :3], (np.eye(3) + skew(th)) @ S0[:3, :3], atol=1e-15)
    assert np.allclose(S[:3, 3], S0[:3, 3] + u, atol=1e-15)
    assert np.allclose(S[3], [0, 0, 0, 1])
    for a in range(3):
        e = np.zeros(3)
        e[a] = H
        fd = (fr.shape(eta + e) - fr.shape(eta - e)) / (2 * H)
        assert _rel(fr.shape_derivatives()[a], fd) < 1e-7
    assert np.allclose(link.frame("body").shape(eta), np.eye(4))
    assert np.allclose(fr.shape(np.zeros(3)), S0)


def test_rotation_helpers():
    w = np.array([0.3, -1.1, 0.5])
    R = exp_so3(w)
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-14)
    assert np.allclose(log_so3(R), w, atol=1e-12)
    w_pi = np.pi * np.array([0.0, 0.6, 0.8])
    assert np.allclose(np.abs(log_so3(exp_so3(w_pi))), np.abs(w_pi), atol=1e-7)
    assert np.allclose(vee(skew(w)), w)
    Hp = frame_from_z([1, 2, 3], [0, 1, 1])
    assert np.allclose(Hp[:3, 2], np.array([0, 1, 1]) / np.sqrt(2))
    assert np.allclose(inverse(Hp) @ Hp, np.eye(4), atol=1e-14)


def test_bad_joint_and_link_input_is_named():
    with pytest.raises(ConfigError, match=r"joint 'j': type: expected one of"):
        Joint("j", "hinge", "a", "body", "b", "body")
    with pytest.raises(ConfigError, match=r"joint 'j': q0: expected 3 finite value"):
        Joint("j", "spherical", "a", "body", "b", "body", (0.1,))
    with pytest.raises(ConfigError, match=r"link 'bar': frame 'tip': pose: expected a rigid"):
        rigid_link("bar", {"tip": 2 * np.eye(4)})
    with pytest.raises(ConfigError, match=r"link 'bar': frame 'nope' does not exist"):
        rigid_link("bar").frame("nope")
