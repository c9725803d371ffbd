"""A spherical joint started exactly at its angles' singular set (|ry| = 90 deg: a legal
pose) stopped with a bare "Singular matrix" (issue 24); the run now names the joint, the
angle and the remedy."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.joints import gimbal_locks
from pipeline.solver import simulate


def _top(ry0: float) -> System:
    mech = build_mechanism([rigid_link("ground"), rigid_link("top")],
                           [Joint("S", "spherical", "ground", "body", "top", "body",
                                  (0.0, ry0, 0.0))])
    return System(mech, {"top": BodyMass.rigid(1.0, [0.1, 0, 0], np.diag([2e-3, 1e-3, 1e-3]))},
                  gravity=[0.0, 0.0, -9.81])


@pytest.mark.parametrize("method", ["DOP853", "generalized_alpha"])
def test_a_start_at_gimbal_lock_names_the_joint_and_the_angle(method):
    s = _top(-np.pi / 2)
    qd0 = np.zeros(3)
    qd0[s.mechanism.index("S.rx")] = 50.0
    r = simulate(s, s.mechanism.q_initial.copy(), qd0, (0.0, 0.1), progress=False,
                 method=method)
    assert r.verdict == "partial"
    assert "joint 'S' (spherical) is at ry = -90 deg" in r.message, r.message
    assert "mid-range orientation" in r.message


def test_gimbal_lock_is_only_at_the_singular_set():
    m = _top(0.0).mechanism
    assert gimbal_locks(m, [0.0, -np.pi / 2, 0.0]) and gimbal_locks(m, [1.0, np.pi / 2, 3.0])
    assert not gimbal_locks(m, [0.0, -np.pi / 2 + 1e-3, 0.0])
    assert not gimbal_locks(m, [0.0, 0.3, 0.0])
