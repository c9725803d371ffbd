"""Held coordinates stay held, given initial values are honoured or refused by name, and a
coordinate that does not move the loops never counts as a constraint direction."""

from __future__ import annotations

import sys
from pathlib import Path

import closed_form
import numpy as np
import pytest
from kin_models import four_bar, slider_crank

from pipeline.core.errors import ConfigError
from pipeline.kinematics import ClosureError, assemble, closure, dof_report, solve_position
from pipeline.kinematics.initial import initial_positions, initial_velocities
from pipeline.kinematics.partition import Partition, normalised_jacobian, numerical_rank

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "solver"))
import excavator


def test_position_analysis_never_moves_an_independent_coordinate():
    """A crank asked for an angle its loop cannot reach used to be moved by the
    least-squares fallback (asked -4.37, returned -7.00) and reported closed."""
    m = four_bar(2.0, 1.0, 2.0, 2.5, theta2=1.2, theta3=0.35, theta4=1.5)  # limited crank
    a = assemble(m, driven=["J2.theta"])
    p = a.partition
    free = Partition(p.rows, p.dependent, np.zeros(0, int), p.prescribed, p.rcond)  # J2 free
    reached = refused = 0
    for th in np.linspace(-7.0, 7.0, 141):
        q = a.q.copy()
        q[0] = th
        try:
            qq = solve_position(m, q, free)[0]
        except ClosureError:
            refused += 1
            continue
        assert qq[0] == th  # held exactly, or refused
        reached += 1
    assert refused > 50 and reached > 20


def test_given_positions_are_held_exactly_when_the_loops_allow():
    m = four_bar(1.0, 2.2, 2.0, 2.5)
    q = initial_positions(m, m.q_initial, given={"J2.theta": 0.9})
    assert q[0] == 0.9
    assert np.abs(closure(m, q).r).max() < 1e-12
    ref = closed_form.four_bar(0.9, 0.0, 0.0, 1.0, 2.2, 2.0, 2.5, branch="open")
    assert abs(q[3] - ref.theta4) < 1e-10


def test_over_determined_positions_are_projected_or_refused_by_name():
    m = four_bar(1.0, 2.2, 2.0, 2.5)
    q_ok = initial_positions(m, m.q_initial, given={"J2.theta": 0.9})
    given = {"J2.theta": 0.9, "J1.theta": float(q_ok[3])}  # consistent, but two of one DOF
    q = initial_positions(m, m.q_initial, given=given)
    assert abs(q[0] - 0.9) < 1e-9 and abs(q[3] - q_ok[3]) < 1e-9
    with pytest.raises(ConfigError, match=r"J2.theta = 0.9 .*allow|J1.theta = .*allow"):
        initial_positions(m, m.q_initial, given={"J2.theta": 0.9, "J1.theta": q_ok[3] + 0.2})


def test_given_velocities_are_honoured_and_the_rest_follow_the_loop():
    m = four_bar(1.0, 2.2, 2.0, 2.5)
    q = initial_positions(m, m.q_initial, given={"J2.theta": 0.9})
    qd = initial_velocities(m, q, given={"J2.theta": 3.0})
    assert qd[0] == 3.0
    assert np.abs(closure(m, q).J @ qd).max() < 1e-12
    ref = closed_form.four_bar(0.9, 3.0, 0.0, 1.0, 2.2, 2.0, 2.5, branch="open")
    assert abs(qd[3] - ref.theta4_d) < 1e-10
    with pytest.raises(ConfigError, match="J1.theta"):
        initial_velocities(m, q, given={"J2.theta": 3.0, "J1.theta": 5.0})


def test_crank_rate_at_top_dead_centre_is_not_dropped():
    """At top dead centre the slider cannot carry the crank's rate; the rate the user gave the
    crank is kept (it used to be read through the slider's zero rate and lost)."""
    m = slider_crank(1.0, 2.5, 0.0, theta0=0.0)
    q = initial_positions(m, m.q_initial, given={"crank.theta": 0.0})
    qd = initial_velocities(m, q, given={"crank.theta": 10.0})
    assert qd[0] == 10.0 and abs(qd[1]) < 1e-12  # slider at rest at TDC
    assert np.abs(closure(m, q).J @ qd).max() < 1e-12


def test_a_coordinate_that_moves_the_loop_rigidly_is_no_constraint_direction():
    """A slewing base under a planar boom/cylinder loop: the slew's column of the loop's
    Jacobian is zero but for round-off; normalising it used to make it a unit column, and
    driving the slew was refused ("over-constrain the mechanism: ... only 3 of its 4")."""
    s, q0 = excavator.build()
    m = s.mechanism
    a = assemble(m, q0, driven=["slew.theta"])
    Jn, _ = normalised_jacobian(m, a.closure.J)
    assert np.abs(Jn[:, m.index("slew.theta")]).max() < 1e-8
    assert numerical_rank(Jn) == 3  # the planar loop's three in-plane rows
    r = dof_report(m, a.q, ["slew.theta", "stroke.d"])
    assert r.free == () and len(r.redundant) == 3


def test_the_reach_of_a_crank_is_the_closed_form():
    """A non-Grashof four-bar (crank 2, coupler 1, rocker 1.5, ground 2): the crank tip A
    stays within b + c of O4 and at least |b - c| from it, so cos theta2 runs from
    (a^2 + d^2 - (b + c)^2) / 2ad to (a^2 + d^2 - (b - c)^2) / 2ad; the free coordinate's
    range is found to 1e-8 rad from inside it."""
    from pipeline.kinematics.initial import reach

    a, b, c, d = 2.0, 1.0, 1.5, 2.0
    m = four_bar(a, b, c, d, theta2=0.6, theta3=1.9, theta4=2.6)
    lo = np.arccos((a * a + d * d - (b - c) ** 2) / (2 * a * d))
    hi = np.arccos((a * a + d * d - (b + c) ** 2) / (2 * a * d))
    got = reach(m, m.q_initial, {"J2.theta": 0.6}, "J2.theta")
    np.testing.assert_allclose(got, (lo, hi), atol=1e-8)
    # a coordinate the loops leave unbounded: a Grashof crank turns all the way round
    g = four_bar(1.0, 3.0, 2.5, 3.0, theta2=0.4, theta3=1.0, theta4=1.8)
    assert reach(g, g.q_initial, {"J2.theta": 0.4}, "J2.theta") == (-np.inf, np.inf)
