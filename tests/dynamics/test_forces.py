"""Force elements: generalized forces equal the virtual work of the physical loads.

Reference, independent of the elements' code: the test builds the physical
force/torque on each marker from marker poses only (``step_pose``), and the
virtual displacement of each marker by central differences of its pose along
every coordinate: Q_i = sum F . dR/dq_i + T . dtheta/dq_i. Conservative
elements also satisfy Q = -dV/dq (central differences of V).
"""

from __future__ import annotations

import numpy as np
import pytest
from dyn2_models import spatial_chain

from pipeline.core.errors import ConfigError
from pipeline.dynamics import System
from pipeline.dynamics.forces import (
    FORCES,
    FollowerForce,
    ForceCylinder,
    JointForce,
    JointSpringDamper,
    LineForce,
    PointForce,
    SpringDamper,
    TableSpringDamper,
    Torque,
)
from pipeline.kinematics import evaluate_tree
from pipeline.kinematics.drivers import Harmonic
from pipeline.kinematics.poses import step_pose

H = 1e-6
MECH = spatial_chain()
SYSTEM = System(MECH, {})
RNG = np.random.default_rng(7)
STATES = [(RNG.uniform(-1.5, 1.5, MECH.n), RNG.uniform(-2, 2, MECH.n), RNG.uniform(0, 2))
          for _ in range(3)]
M1, M2, M3 = ("L1", "m1"), ("L2", "tip"), ("L3", "m3")
MID, GND = ("L2", "mid"), ("ground", "anchor")
TABLE = {"deflection": (-0.5, -0.1, 0.0, 0.2, 1.0), "force": (-900.0, -100.0, 0.0, 150.0, 2000.0)}


def pose(marker, q):
    return step_pose(MECH.marker(*marker), evaluate_tree(MECH, q, derivatives=False).A, q)


def point(marker, q, offset=(0.0, 0.0, 0.0)):
    return (pose(marker, q) @ np.append(offset, 1.0))[:3]


def rate(f, q, qd):
    return (f(q + H * qd) - f(q - H * qd)) / (2 * H)


# physical loads per element: list of (marker, offset, force (3,), torque (3,)) at (q, qd, t)
def _spring_loads(a, b, tension):
    def loads(q, qd, t):
        d = point(b, q) - point(a, q)
        ldot = rate(lambda x: np.linalg.norm(point(b, x) - point(a, x)), q, qd)
        f = tension(np.linalg.norm(d), ldot) * d / np.linalg.norm(d)
        return [(a, None, f, None), (b, None, -f, None)]
    return loads


def _table_tension(x, ldot, c):
    return np.interp(x - 0.3, TABLE["deflection"], TABLE["force"]) + c * ldot


CASES = {
    "spring": (SpringDamper("s", M1, M3, stiffness=2e3, free_length=0.3, damping=40.0,
                            preload=15.0),
               _spring_loads(M1, M3, lambda l, ld: 15.0 + 2e3 * (l - 0.3) + 40.0 * ld)),
    "table": (TableSpringDamper("tb", GND, MID, free_length=0.3, damping=25.0, **TABLE),
              _spring_loads(GND, MID, lambda l, ld: _table_tension(l, ld, 25.0))),
    "point": (PointForce("p", M2, (3.0, -4.0, 12.0), offset=(0.1, 0.0, -0.2)),
              lambda q, qd, t: [(M2, (0.1, 0.0, -0.2), np.array([3.0, -4.0, 12.0]), None)]),
    "point_history": (PointForce("ph", M3, (1.0, 2.0, -3.0), history=Harmonic(0.5, 1.3)),
                      lambda q, qd, t: [(M3, None, Harmonic(0.5, 1.3).value(t)
                                         * np.array([1.0, 2.0, -3.0]), None)]),
    "follower": (FollowerForce("f", MID, (5.0, 1.0, -2.0), offset=(0.0, 0.3, 0.0)),
                 lambda q, qd, t: [(MID, (0.0, 0.3, 0.0),
                                    pose(MID, q)[:3, :3] @ [5.0, 1.0, -2.0], None)]),
    "line": (LineForce("l", M1, M2, 250.0),
             lambda q, qd, t: [(M2, None, 250.0 * _u(M1, M2, q), None),
                               (M1, None, -250.0 * _u(M1, M2, q), None)]),
    "torque": (Torque("t", M2, (2.0, -1.0, 3.0)),
               lambda q, qd, t: [(M2, None, None, np.array([2.0, -1.0, 3.0]))]),
    "torque_follower": (Torque("tf", M3, (0.5, 4.0, -1.0), follower=True),
                        lambda q, qd, t: [(M3, None, None, pose(M3, q)[:3, :3] @ [0.5, 4, -1])]),
}


def _u(a, b, q):
    d = point(b, q) - point(a, q)
    return d / np.linalg.norm(d)


def virtual_work_Q(loads, q, qd, t):
    """Q_i = sum F . dR/dq_i + T . dtheta/dq_i from central differences of marker poses."""
    Q = np.zeros(MECH.n)
    for marker, offset, F, Tq in loads(q, qd, t):
        off = (0.0, 0.0, 0.0) if offset is None else offset
        for i in range(MECH.n):
            e = np.zeros(MECH.n)
            e[i] = 1.0
            if F is not None:
                Q[i] += F @ rate(lambda x, m=marker, o=off: point(m, x, o), q, e)
            if Tq is not None:
                Rd = rate(lambda x, m=marker: pose(m, x)[:3, :3], q, e)
                W = Rd @ pose(marker, q)[:3, :3].T
                Q[i] += Tq @ (0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0],
                                              W[1, 0] - W[0, 1]]))
    return Q


@pytest.mark.parametrize("case", sorted(CASES))
def test_generalized_force_is_virtual_work_of_the_physical_loads(case):
    element, loads = CASES[case]
    element.validate(SYSTEM)
    for q, qd, t in STATES:
        tree = evaluate_tree(MECH, q)
        Q = element.generalized_force(SYSTEM, tree, q, qd, t)
        ref = virtual_work_Q(loads, q, qd, t)
        assert np.abs(Q - ref).max() <= 1e-7 * np.abs(ref).max(), (case, Q, ref)
        assert np.isclose(element.power(SYSTEM, tree, q, qd, t), Q @ qd, rtol=1e-13)


def _grad_V(element, q):
    def V(x):
        return element.potential_energy(SYSTEM, evaluate_tree(MECH, x), x)
    return np.array([rate(V, q, e) for e in np.eye(MECH.n)])


@pytest.mark.parametrize("element", [
    SpringDamper("s", M1, M3, stiffness=2e3, free_length=0.3, preload=15.0),
    TableSpringDamper("tb", GND, MID, free_length=0.3, **TABLE),
    PointForce("p", M2, (3.0, -4.0, 12.0), offset=(0.1, 0.0, -0.2)),
    LineForce("l", M1, M2, 250.0),
    JointSpringDamper("js", "J2.theta", stiffness=40.0, free_value=0.2),
    JointForce("jf", "J3.d", 30.0),
], ids=lambda e: type(e).__name__)
def test_conservative_elements_have_Q_equal_minus_grad_V(element):
    assert element.conservative
    for q, _, t in STATES:
        Q = element.generalized_force(SYSTEM, evaluate_tree(MECH, q), q, None, t)
        ref = -_grad_V(element, q)
        assert np.abs(Q - ref).max() <= 1e-7 * np.abs(ref).max()


def test_joint_elements_act_on_their_coordinate_only():
    q, qd, t = STATES[0]
    tree = evaluate_tree(MECH, q)
    js = JointSpringDamper("js", "J1.theta", stiffness=40.0, free_value=0.2, damping=3.0)
    Q = js.generalized_force(SYSTEM, tree, q, qd, t)
    assert Q[0] == pytest.approx(-40.0 * (q[0] - 0.2) - 3.0 * qd[0], rel=1e-15)
    assert not np.any(Q[1:])
    cyl = ForceCylinder("cyl", "J3.d", 1.0, history=lambda s: 1e3 * s)
    cyl.validate(SYSTEM)
    Q = cyl.generalized_force(SYSTEM, tree, q, qd, 0.7)
    assert Q[MECH.index("J3.d")] == pytest.approx(700.0) and np.count_nonzero(Q) == 1
    assert not cyl.conservative and cyl.potential_energy(SYSTEM, tree, q) == 0.0


def test_non_conservative_elements_store_no_energy():
    q = STATES[1][0]
    tree = evaluate_tree(MECH, q)
    for key in ("follower", "point_history", "torque", "torque_follower"):
        assert CASES[key][0].potential_energy(SYSTEM, tree, q) == 0.0
        assert not CASES[key][0].conservative


def test_registry_and_bad_input_name_the_element():
    assert FORCES["spring_damper"] is SpringDamper
    assert {"table_spring_damper", "joint_spring_damper", "point_force", "follower_force",
            "line_force", "torque", "joint_force", "force_cylinder",
            "hydraulic_cylinder"} < set(FORCES)
    with pytest.raises(ConfigError, match="'s': stiffness: expected a finite value >= 0"):
        SpringDamper("s", M1, M3, stiffness=-1.0)
    with pytest.raises(ConfigError, match="'bad': marker_b"):
        SpringDamper("bad", M1, ("L3",)).validate(SYSTEM)
    with pytest.raises(ConfigError, match="frame 'nope' does not exist"):
        PointForce("p", ("L2", "nope"), (0, 0, 1)).validate(SYSTEM)
    with pytest.raises(ConfigError, match="'cyl': coordinate: expected the stroke"):
        ForceCylinder("cyl", "J1.theta").validate(SYSTEM)
    with pytest.raises(ConfigError, match="'tb': deflection: expected at least 2 strictly"):
        TableSpringDamper("tb", M1, M3, deflection=(0.0, 0.0), force=(1.0, 2.0))
    with pytest.raises(ConfigError, match="'j': coordinate: coordinate 'x.d' does not exist"):
        JointForce("j", "x.d").validate(SYSTEM)


def test_damped_spring_splits_its_non_conservative_part():
    """Q(q, q') = -dV/dq + Q_nc with Q_nc the damper alone (-c l' dl/dq, l' by FD in time)."""
    s = SpringDamper("s", M1, M3, stiffness=2e3, free_length=0.3, damping=40.0, preload=15.0)
    js = JointSpringDamper("js", "J2.theta", stiffness=40.0, damping=3.0)
    assert not s.conservative and not js.conservative
    for q, qd, t in STATES:
        tree = evaluate_tree(MECH, q)
        Q = s.generalized_force(SYSTEM, tree, q, qd, t)
        Qnc = s.nonconservative_force(SYSTEM, tree, q, qd, t)
        assert np.abs(Q - Qnc + _grad_V(s, q)).max() <= 1e-7 * np.abs(Q).max()
        ldot = rate(lambda x: np.linalg.norm(point(M3, x) - point(M1, x)), q, qd)
        assert Qnc @ qd == pytest.approx(-40.0 * ldot**2, rel=1e-8)
        Qj = js.nonconservative_force(SYSTEM, tree, q, qd, t)
        assert Qj[1] == -3.0 * qd[1] and np.count_nonzero(Qj) == 1


@pytest.mark.parametrize("case", sorted(CASES))
def test_physical_loads_listed_for_reactions_match_the_reference_loads(case):
    element, loads = CASES[case]
    for q, qd, t in STATES:
        tree = evaluate_tree(MECH, q)
        got = sorted(element.loads(SYSTEM, tree, q, qd, t), key=lambda ld: ld.link)
        ref = sorted(loads(q, qd, t), key=lambda r: MECH.marker(*r[0]).frm)
        ref = sorted(ref, key=lambda r: r[0][0])
        assert [g.link for g in got] == [r[0][0] for r in ref]
        for g, (marker, offset, F, Tq) in zip(got, ref):
            off = (0.0, 0.0, 0.0) if offset is None else offset
            assert np.allclose(g.point, point(marker, q, off), atol=1e-14)
            assert np.allclose(g.force, np.zeros(3) if F is None else F, rtol=1e-12, atol=1e-9)
            assert np.allclose(g.torque, np.zeros(3) if Tq is None else Tq, rtol=1e-12)


def test_histories_at_many_times_are_the_histories_at_each():
    """The force factors of a run are evaluated for all its step times at once (drivers
    take arrays): the same values as one time at a time (to the last bit or two: numpy's
    array and scalar arithmetic may round apart), for a driver, a sum of drivers, a
    controller's reference and its rate, a user's callable and a number."""
    from pipeline.dynamics.forces.hydraulics import PID
    from pipeline.dynamics.forces.loads import (
        history_rate,
        history_rates,
        history_value,
        history_values,
    )
    from pipeline.kinematics.drivers import SmoothStep

    times = np.linspace(-0.1, 1.3, 57)
    ramp = SmoothStep(0.1, 0.9, 0.2, 1.4)
    for h in (ramp, ramp + Harmonic(0.3, 2.0), PID(ramp, kp=2.0), lambda t: np.sin(3 * t),
              2.5):
        got = history_values(h, times)
        assert got.shape == times.shape
        np.testing.assert_allclose(got, [history_value(h, float(t), "h") for t in times],
                                   rtol=4e-16, atol=4e-16)
        rates = history_rates(h, times)
        np.testing.assert_allclose(rates, [history_rate(h, float(t)) for t in times],
                                   rtol=4e-16, atol=2e-15)
    assert history_rates(PID(ramp, kp=2.0), times).any()  # the reference's rate
