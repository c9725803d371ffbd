"""Failures that help: bad topology, loops that cannot close, singular configurations."""

from __future__ import annotations

import numpy as np
import pytest
from kin_models import four_bar

from pipeline.core.errors import ConfigError, KinematicsError
from pipeline.kinematics import (
    ClosureError,
    Joint,
    SingularConfigurationError,
    assemble,
    build_mechanism,
    flexible_link,
    rigid_link,
    sweep,
)
from pipeline.kinematics.drivers import Ramp
from pipeline.kinematics.rotations import translation as T


def _pin(name, p, pf, c, cf):
    return Joint(name, "revolute", p, pf, c, cf)


def test_disconnected_links_are_named():
    links = [rigid_link("ground"), rigid_link("arm"), rigid_link("lost"), rigid_link("alone")]
    joints = [_pin("j1", "ground", "body", "arm", "body"), _pin("j2", "lost", "body", "alone",
                                                                "body")]
    with pytest.raises(KinematicsError, match=r"not connected to ground 'ground': \['lost', "
                                              r"'alone'\]"):
        build_mechanism(links, joints)


def test_missing_frame_link_and_ground_are_named():
    links = [rigid_link("ground"), rigid_link("arm", {"tip": T([1, 0, 0])})]
    with pytest.raises(ConfigError, match=r"joint 'j1': child_frame: link 'arm': frame 'tpi' "
                                          r"does not exist; frames: \['body', 'tip'\]"):
        build_mechanism(links, [_pin("j1", "ground", "body", "arm", "tpi")])
    with pytest.raises(ConfigError, match=r"joint 'j1': parent: link 'grnd' does not exist"):
        build_mechanism(links, [_pin("j1", "grnd", "body", "arm", "body")])
    with pytest.raises(ConfigError, match=r"ground: link 'base' does not exist"):
        build_mechanism(links, [_pin("j1", "ground", "body", "arm", "body")], ground="base")


def test_two_joints_between_the_same_frames():
    links = [rigid_link("ground"), rigid_link("arm")]
    joints = [_pin("j1", "ground", "body", "arm", "body"),
              Joint("j2", "prismatic", "arm", "body", "ground", "body")]
    with pytest.raises(ConfigError, match=r"joints 'j1' and 'j2' connect the same frames"):
        build_mechanism(links, joints)


def test_duplicate_names_and_self_joint():
    with pytest.raises(ConfigError, match=r"links: duplicate name\(s\) \['arm'\]"):
        build_mechanism([rigid_link("ground"), rigid_link("arm"), rigid_link("arm")], [])
    with pytest.raises(ConfigError, match=r"joint 'j': parent and child are the same link"):
        build_mechanism([rigid_link("ground"), rigid_link("arm", {"a": T([1, 0, 0])})],
                        [_pin("j0", "ground", "body", "arm", "body"),
                         _pin("j", "arm", "body", "arm", "a")])


def test_flexible_link_reachable_only_through_deforming_frames():
    phi = np.array([[0.0, 0.1, 0.0]])
    beam = flexible_link("beam", {"tip": (T([1, 0, 0]), phi, np.zeros((1, 3)))})
    links = [rigid_link("ground"), beam]
    with pytest.raises(KinematicsError, match=r"flexible link\(s\) \['beam'\] can only be "
                                              r"reached through frames that move"):
        build_mechanism(links, [_pin("j", "ground", "body", "beam", "tip")])


def test_loop_that_cannot_close_names_loop_residual_and_closest_configuration():
    a, b, c, d, th = 0.04, 0.03, 0.02, 0.10, 0.4  # b + c < |O4 - A|: no assembly
    m = four_bar(a, b, c, d, th)
    with pytest.raises(ClosureError) as info:
        assemble(m, driven=["J2.theta"])
    exc = info.value
    assert exc.loop == "L1" and exc.cut_joint == "J4"
    assert "loop 'L1' (cut joint 'J4'" in str(exc) and "cannot close" in str(exc)
    # closest configuration: coupler and rocker stretched along A -> O4, the gap
    # |O4 - A| - b - c remains (independent geometry)
    A = a * np.array([np.cos(th), np.sin(th)])
    gap = np.linalg.norm(np.array([d, 0.0]) - A) - b - c
    assert np.isclose(np.linalg.norm(exc.residual[:3]), gap, rtol=1e-6)
    assert f"{gap:.3e}" in str(exc)
    q = exc.q_closest
    theta3, theta4 = q[0] + q[1], q[3]
    direction = np.arctan2(-A[1], d - A[0])
    assert abs(np.angle(np.exp(1j * (theta3 - direction)))) < 1e-5
    assert abs(np.angle(np.exp(1j * (theta4 - direction - np.pi)))) < 1e-5
    assert q[0] == th  # the driven coordinate is kept


def Linear(v0, w):
    """Coordinate v0 + w t (t >= 0)."""
    return Ramp(t0=0.0, slope=w, v0=v0)


def test_singular_configuration_names_joints_time_and_driver():
    """Parallelogram four-bar: at crank angle 0 all links are collinear and the
    constraint rank drops (the parallelogram/antiparallelogram bifurcation)."""
    m = four_bar(0.05, 0.1, 0.05, 0.1, -0.5, 0.0, -0.5)
    res = sweep(m, {"J2.theta": Linear(-0.5, 1.0)}, np.linspace(0.0, 1.0, 21))
    assert not res.success and res.n_done == 10
    assert "singular configuration at t = 0.5 s with J2.theta = 0" in res.message
    assert "joints losing rank: ['J3', 'J4', 'J1']" in res.message
    # results before the singularity are kept, the rest is NaN
    assert np.all(np.isfinite(res.q[:10])) and np.all(np.isnan(res.q[10:]))
    # parallelogram branch up to there: coupler stays horizontal, rocker = crank
    assert np.allclose(res.q[:10, 0] + res.q[:10, 1], 0.0, atol=1e-12)
    assert np.allclose(res.q[:10, 3], res.q[:10, 0], atol=1e-12)


def test_singular_exception_carries_context():
    from pipeline.kinematics.closure import closure
    from pipeline.kinematics.partition import select_partition

    m = four_bar(0.05, 0.1, 0.05, 0.1)
    q = np.zeros(4)  # the collinear configuration itself
    with pytest.raises(SingularConfigurationError) as info:
        select_partition(m, closure(m, q).J, [0], t=1.25, drivers={"J2.theta": 0.0}, q=q,
                         expected_rank=3)
    exc = info.value
    assert exc.t == 1.25 and exc.drivers == {"J2.theta": 0.0} and exc.joints == ("J3", "J4", "J1")


def test_over_driven_mechanism_is_reported():
    m = four_bar(0.04, 0.12, 0.09, 0.10)
    with pytest.raises(KinematicsError, match=r"driven coordinates \['J2.theta', 'J1.theta'\] "
                                              r"over-constrain the mechanism"):
        assemble(m, driven=["J2.theta", "J1.theta"])


def test_bad_sweep_input():
    m = four_bar(0.04, 0.12, 0.09, 0.10)
    with pytest.raises(ConfigError, match=r"t: expected a non-empty 1-D array"):
        sweep(m, {"J2.theta": Linear(0, 1)}, [0.0, 0.0])
    with pytest.raises(ConfigError, match=r"coordinate 'J9.theta' does not exist"):
        sweep(m, {"J9.theta": Linear(0, 1)}, [0.0, 1.0])


def test_singular_joints_with_fewer_candidates_than_constraints():
    """Rank lost because too few coordinates remain: all of them are named, no crash."""
    from pipeline.kinematics.partition import singular_joints

    m = four_bar(0.04, 0.12, 0.09, 0.10)
    cand = np.array([1, 2])
    B = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    names = singular_joints(m, B, cand, expected_rank=3)
    assert set(names) == {m.joint_of(1), m.joint_of(2)}
