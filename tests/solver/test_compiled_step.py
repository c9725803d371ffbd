"""The compiled index-3 step and output state equal their numpy reference (index3.py,
constrained.py, outputs.py) on machines that use every compiled ingredient: closed loops
with redundant rows, drivers, flexible links, joint springs, point-to-point springs, a
motor torque, a load with a time history, an open chain (no closure rows), and a flexible
link with second-order frames and mass moments (geometric stiffening)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import andrews as A
import excavator
from eom_models import flexible_double_pendulum, flexible_four_bar

from pipeline.dynamics import System
from pipeline.dynamics.forces import (
    FORCES,
    FollowerForce,
    ForceElement,
    JointSpringDamper,
    LineForce,
    PointForce,
    SpringDamper,
    TableSpringDamper,
    Torque,
)
from pipeline.kinematics import assemble
from pipeline.kinematics.drivers import Ramp, SmoothStep
from pipeline.kinematics.initial import initial_positions, initial_velocities
from pipeline.solver import simulate
from pipeline.solver.constrained import ConstrainedSystem
from pipeline.solver.index3 import Index3Stepper
from pipeline.solver.index3_compiled import CompiledStepper, stepper
from pipeline.solver.outputs import OutputGrid


def _excavator():
    s, q0 = excavator.build()
    load = PointForce("load", ("boom", "rod"), (0.0, 0.0, -2000.0),
                      history=SmoothStep(0.0, 0.05, 0.0, 1.0))
    # loads in a spatial machine, where loads fixed to a frame and in ground axes differ
    turned = (Torque("tilt", ("boom", "rod"), (0.5, -1.0, 2.0), follower=True),
              Torque("twist", ("base", "pivot"), (1.0, 0.5, -0.3)),
              FollowerForce("drag", ("boom", "rod"), (10.0, 0.0, -5.0), offset=(0.2, 0.0, 0.0)))
    drivers = {"slew.theta": Ramp(0.0, 0.5, 0.7)}
    system = System(s.mechanism, s.bodies, s.gravity, forces=s.forces + (load,) + turned,
                    drivers=drivers)
    q = initial_positions(s.mechanism, q0, {"slew.theta": 0.7})
    return system, q, initial_velocities(s.mechanism, q, {"slew.theta": 0.5})


def _andrews():
    s = A.pipeline_model()
    q0, qd0 = A.pipeline_initial(s)
    return s, q0, qd0


def _flexible_four_bar(second_order=False):
    s = flexible_four_bar(n_modes=2, second_order=second_order).system
    spring = JointSpringDamper("spring", "J2.theta", stiffness=30.0, free_value=1.0,
                               damping=0.5)
    # second order: a load at the coupler's frame B, whose second-order translation it
    # works through (the compiled marker points carry it)
    push = (PointForce("push", ("coupler", "B"), (30.0, -20.0, 0.0)),) if second_order else ()
    s = System(s.mechanism, s.bodies, s.gravity, forces=(spring,) + push)
    q0 = assemble(s.mechanism, s.mechanism.q_initial).q
    return s, q0, initial_velocities(s.mechanism, q0, given={"J2.theta": 2.0})


def _every_kind():
    """The flexible four-bar with an element of every compiled kind, several on the
    flexible coupler's frame B (its elastic rotation turns the follower loads)."""
    s, q0, qd0 = _flexible_four_bar()
    ramp = SmoothStep(0.0, 0.05, 0.2, 1.0)
    forces = (
        JointSpringDamper("spring", "J2.theta", stiffness=30.0, free_value=1.0, damping=0.5),
        SpringDamper("strut", ("ground", "O4"), ("coupler", "B"), stiffness=200.0,
                     free_length=1.0, damping=2.0, preload=5.0),
        TableSpringDamper("table", ("ground", "body"), ("crank", "A"), free_length=0.5,
                          deflection=(-1.0, 0.2, 0.6, 2.0), force=(-40.0, 5.0, 30.0, 90.0),
                          damping=1.0),
        PointForce("push", ("coupler", "B"), (30.0, -20.0, 0.0), offset=(0.1, 0.05, 0.0)),
        FollowerForce("follower", ("coupler", "B"), (0.0, 25.0, 0.0), offset=(-0.2, 0.0, 0.0),
                      history=ramp),
        LineForce("line", ("ground", "body"), ("coupler", "B"), 15.0),
        LineForce("line_ramp", ("ground", "O4"), ("crank", "A"), -10.0, history=ramp),
        Torque("torque", ("coupler", "B"), (0.0, 0.0, 4.0)),
        Torque("follower_torque", ("rocker", "B"), (0.0, 0.0, -3.0), follower=True,
               history=ramp),
    )
    return System(s.mechanism, s.bodies, s.gravity, forces=forces), q0, qd0


def _pendulum():
    s = flexible_double_pendulum(n_modes=2, k_scale=2e4).system
    q0 = np.zeros(s.mechanism.n)
    return s, q0, q0


CASES = {"excavator": (_excavator, 2e-3), "andrews": (_andrews, 1e-5),
         "every force element kind": (_every_kind, 2e-3),
         "flexible four-bar": (_flexible_four_bar, 2e-3), "open chain": (_pendulum, 2e-3),
         "second-order frames and mass moments":
             (lambda: _flexible_four_bar(second_order=True), 2e-3)}


@pytest.mark.parametrize("case", sorted(CASES))
def test_compiled_steps_equal_the_numpy_reference(case):
    build, h = CASES[case]
    system, q0, qd0 = build()
    cs = ConstrainedSystem(system)
    kw = {"rho_inf": 0.8, "newton_rtol": 1e-9, "newton_atol": 1e-11,
          "unit": system.mechanism.coordinate_units}
    ref, fast = Index3Stepper(cs, **kw), stepper(cs, **kw)
    assert isinstance(fast, CompiledStepper)
    a, b = ref.start(0.0, q0, qd0), fast.start(0.0, q0, qd0)
    for _ in range(30):
        oa, ob = ref.step(a, h), fast.step(b, h)
        assert oa.iterations == ob.iterations and oa.why == ob.why == ""
        a, b = oa.state, ob.state
        # q'' = q''_pred + beta' dq: a rounding-level difference of q shows there amplified
        # by 1 / (beta h^2) (3e10 at Andrews' 10 us step)
        for x, y, tol in ((a.q, b.q, 1e-11), (a.v, b.v, 1e-10), (a.qdd, b.qdd, 1e-7),
                          (a.powers, b.powers, 1e-8)):
            assert np.abs(x - y).max() <= tol * (1.0 + np.abs(x).max())
    grid_a = OutputGrid(cs, np.array([a.t]))
    grid_b = OutputGrid(cs, np.array([a.t]), fast.output)
    rng = np.random.default_rng(3)
    q, v = a.q + 1e-5 * rng.standard_normal(a.q.size), a.v  # off the loops: projected
    grid_a.record(a.t, q, v, np.zeros(2))
    grid_b.record(a.t, q, v, np.zeros(2))
    ra, rb = grid_a.rows[0], grid_b.rows[0]
    for j in (1, 2, 3, 6, 7):
        x, y = np.asarray(ra[j]), np.asarray(rb[j])
        assert np.abs(x - y).max(initial=0.0) <= 1e-9 * (1.0 + np.abs(x).max(initial=0.0))
    for k in ("kinetic", "gravity", "elastic", "forces"):
        assert abs(ra[4][k] - rb[4][k]) <= 1e-9 * (1.0 + abs(ra[4][k]))


def test_a_stretch_of_steps_in_one_call_equals_single_steps():
    system, q0, qd0 = _excavator()
    cs = ConstrainedSystem(system)
    one, many = stepper(cs), stepper(cs)
    s = one.start(0.0, q0, qd0)
    work = np.zeros(2)
    for _ in range(25):
        s1 = one.step(s, 2e-3).state
        work = work + 1e-3 * (s.powers + s1.powers)
        s = s1
    done, why, before, last, work_m = many.march(many.start(0.0, q0, qd0), 2e-3, 25,
                                                 np.zeros(2))
    assert done == 25 and why == ""
    assert np.abs(last.q - s.q).max() < 1e-12 and np.abs(work_m - work).max() < 1e-9
    assert abs(before[0] - (s.t - 2e-3)) < 1e-15


def test_every_force_element_class_has_a_compiled_form():
    """Each element class the workflows offer has a kind, a pack and kernels, and the
    kinds are distinct: adding a class without them fails here."""
    from pipeline.dynamics.forces.compiled import KERNELS

    for name, cls in FORCES.items():
        assert cls.KIND in KERNELS and cls in KERNELS[cls.KIND][0], name
        assert "pack" in vars(cls) or any("pack" in vars(b) for b in cls.__mro__[1:-1]), name
    classes = [c for entry in KERNELS.values() for c in entry[0]]
    assert len(classes) == len(set(classes)) and set(FORCES.values()) <= set(classes)


def test_a_users_own_element_takes_the_numpy_step_and_says_so(caplog):
    from dataclasses import dataclass

    @dataclass(frozen=True)
    class Viscous(ForceElement):
        name: str

        def _force(self, system, tree, q, qd, t):
            return -0.3 * qd

        def loads(self, system, tree, q, qd, t):
            return ()

    s, q0, qd0 = _flexible_four_bar()
    s2 = System(s.mechanism, s.bodies, s.gravity, forces=(Viscous("drag"),))
    with caplog.at_level("WARNING", logger="pipeline.solver.dae_data"):
        assert isinstance(stepper(ConstrainedSystem(s2)), Index3Stepper)
    assert "['drag'] have no compiled form" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="pipeline.solver.dae_data"):
        r = simulate(s2, q0, qd0, (0.0, 0.05), method="generalized_alpha", step=1e-3,
                     progress=False, rtol=1e-4, atol=1e-6)  # the error a 1 ms step meets
    # once per run: its check at twice the step does not say it again
    assert caplog.text.count("have no compiled form") == 1
    assert r.success
