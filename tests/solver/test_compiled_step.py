"""The compiled index-3 step and output state equal their numpy reference (index3.py,
constrained.py, outputs.py) on machines that use every compiled ingredient: closed loops
with redundant rows, drivers, flexible links, joint springs, point-to-point springs, a
motor torque, a load with a time history, an open chain (no closure rows), and a flexible
link with second-order frames and mass moments (geometric stiffening)."""

from __future__ import annotations

import sys
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import andrews as A
import excavator
from eom_models import flexible_double_pendulum, flexible_four_bar
from index3_numpy import Index3Stepper

from pipeline.core.errors import ConfigError
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
from pipeline.dynamics.forces.compiled import uncompiled
from pipeline.kinematics import assemble
from pipeline.kinematics.drivers import Ramp, SmoothStep
from pipeline.kinematics.initial import initial_positions, initial_velocities
from pipeline.solver import simulate
from pipeline.solver.constrained import ConstrainedSystem
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


def _pendulum_loaded():
    """The open chain with a load on its first link only: the step derives the second
    link's pose in its own coordinates only (dae_data.derivatives_needed)."""
    s, q0, qd0 = _pendulum()
    load = PointForce("push", ("link1", "B"), (3.0, -20.0, 0.0), offset=(-0.1, 0.02, 0.0))
    return System(s.mechanism, s.bodies, s.gravity, forces=(load,)), q0, qd0


def test_the_step_derives_the_poses_only_where_its_equations_read_them():
    """dA complete at the force elements' markers and the loops' ends (and their
    ancestors), elsewhere only in each link's own coordinates: an open chain without
    elements has none complete, a load on its first link makes that one complete."""
    from pipeline.solver.dae_data import compile_dae

    for build, whole in ((_pendulum, []), (_pendulum_loaded, ["link1"]),
                         (_every_kind, ["crank", "coupler", "rocker"])):
        system, _, _ = build()
        cs = ConstrainedSystem(system)
        mech = system.mechanism
        derive = compile_dae(system, cs.U, cs.P).kin.derive
        assert sorted(mech.links[i].name for i in np.flatnonzero(derive)) == sorted(whole)


CASES = {"excavator": (_excavator, 2e-3), "andrews": (_andrews, 1e-5),
         "open chain loaded on its first link": (_pendulum_loaded, 2e-3),
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


def test_outputs_recorded_inside_a_stretch_equal_those_recorded_step_by_step():
    """The compiled march records the output times it passes (Hermite between step ends,
    the consistent state of ``output`` there) as the Python loop does after each step;
    the elements' own states (the hydraulic cylinder's pressures) included."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_hydraulic_cylinder import PA0, PB0, S0, _lift

    lift, _ = _lift(SmoothStep(0.0, 0.02, 0.0, 0.6))
    cases = [(*_excavator(), None), (lift, np.array([S0]), np.zeros(1),
                                     np.array([PA0, PB0]))]
    for system, q0, qd0, z0 in cases:
        cs = ConstrainedSystem(system)
        h, count = 2e-3, 25
        te = np.concatenate([[0.0037, 0.01, 0.0101], np.linspace(0.012, count * h, 9)])
        for positions_only in (False, True):
            one, many = stepper(cs), stepper(cs)
            a = OutputGrid(cs, te, one.output, positions_only)
            b = OutputGrid(cs, te, many.output, positions_only)
            s, work = one.start(0.0, q0, qd0, z0), np.zeros(2)
            for _ in range(count):
                s1 = one.step(s, h).state
                work1 = work + 0.5 * h * (s.powers + s1.powers)
                a.fill_hermite(s.t, s.q, s.v, work, s1.t, s1.q, s1.v, work1,
                               (s.z, s.zd, s1.z, s1.zd) if s.z.size else None)
                s, work = s1, work1
            done, why, _, _, _ = many.march(many.start(0.0, q0, qd0, z0), h, count,
                                               np.zeros(2), b)
            assert done == count and why == "" and a.k == b.k == te.size
            for ra, rb in zip(a.rows, b.rows):
                assert ra[0] == rb[0]
                for j in (1, 2, 3, 6, 7, 8):
                    x, y = np.asarray(ra[j]), np.asarray(rb[j])
                    assert np.abs(x - y).max(initial=0.0) <= 1e-12 * (
                        1.0 + np.abs(x).max(initial=0.0)), (j, positions_only)
                for k in ra[4]:
                    assert abs(ra[4][k] - rb[4][k]) <= 1e-12 * (1.0 + abs(ra[4][k])), k


def test_every_force_element_class_has_a_compiled_form():
    """Each element class of the element modules has a kind, a YAML type, a pack and
    kernels (a push for a line element, else a force; a potential; rates where it has
    states), and the kinds are distinct: adding a class without them fails here."""
    import inspect

    from pipeline.dynamics.forces.base import CompiledElement, LineElement
    from pipeline.dynamics.forces.compiled import KERNELS, element_modules

    defined = {cls for m in element_modules() for _, cls in inspect.getmembers(m, inspect.isclass)
               if issubclass(cls, CompiledElement) and cls.__module__ == m.__name__}
    assert len(defined) >= 10 and set(FORCES.values()) == defined
    for name, cls in FORCES.items():
        assert cls.KIND in KERNELS and cls in KERNELS[cls.KIND].classes, name
        assert vars(cls)["TYPE"] == name
        assert "pack" in vars(cls) or any("pack" in vars(b) for b in cls.__mro__[1:-1]), name
        k = KERNELS[cls.KIND]
        assert k.potential is not None, name
        assert (k.push is not None) if issubclass(cls, LineElement) else \
            (k.force is not None and k.push is None), name
        assert (k.rates is not None) == bool(cls.STATES), name
        on_coordinate = "coordinate" in {f.name for f in fields(cls)}
        assert k.push is not None or (k.loads is None) == on_coordinate, name
    classes = [c for entry in KERNELS.values() for c in entry.classes]
    assert len(classes) == len(set(classes)) and set(FORCES.values()) == set(classes)


def _in_python(element):
    """The same element evaluated by the numpy oracle (tests/dynamics/forces_numpy.py) as
    an element without a compiled form: called back from the compiled step."""
    from forces_numpy import NumpyElement

    return NumpyElement.of(element)


def _step_both(a_system, b_system, q0, qd0, h, steps, z=None):
    kw = {"rho_inf": 0.8, "newton_rtol": 1e-9, "newton_atol": 1e-11,
          "unit": a_system.mechanism.coordinate_units}
    a_run = stepper(ConstrainedSystem(a_system), **kw)
    b_run = stepper(ConstrainedSystem(b_system), **kw)
    a, b = a_run.start(0.0, q0, qd0, z), b_run.start(0.0, q0, qd0, z)
    for _ in range(steps):
        oa, ob = a_run.step(a, h), b_run.step(b, h)
        assert oa.iterations == ob.iterations and oa.why == ob.why == ""
        a, b = oa.state, ob.state
    return a, b, a_run, b_run


def test_elements_called_back_in_python_step_as_their_compiled_kernels():
    """Every compiled kind, each also as a class without a compiled form: the compiled step
    calling the numpy methods back gives the compiled kernels' steps and energies."""
    system, q0, qd0 = _every_kind()
    twins = System(system.mechanism, system.bodies, system.gravity,
                   forces=tuple(_in_python(f) for f in system.forces))
    assert len(uncompiled(twins.forces)) == len(system.forces)
    a, b, fast, slow = _step_both(system, twins, q0, qd0, 2e-3, 30)
    for x, y, tol in ((a.q, b.q, 1e-12), (a.v, b.v, 1e-11), (a.lam, b.lam, 1e-9),
                      (a.powers, b.powers, 1e-10)):
        assert np.abs(x - y).max() <= tol * (1.0 + np.abs(x).max())
    ea, eb = fast.output(a.t, a.q, a.v)[5], slow.output(b.t, b.q, b.v)[5]
    for k in ea:
        assert abs(ea[k] - eb[k]) <= 1e-10 * (1.0 + abs(ea[k])), k


def test_an_element_with_states_called_back_in_python_integrates_them_alike():
    """The hydraulic cylinder (two chamber pressures) as a class without a compiled form:
    its pressures and the motion step as the compiled cylinder's."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_hydraulic_cylinder import PA0, PB0, S0, _lift

    command = SmoothStep(0.0, 0.05, 0.0, 0.6)
    system, cyl = _lift(command)
    twins = System(system.mechanism, system.bodies, system.gravity,
                   forces=(_in_python(cyl),))
    q0, z0 = np.array([S0]), np.array([PA0, PB0])
    a, b, _, _ = _step_both(system, twins, q0, np.zeros(1), 1e-3, 60, z0)
    assert a.q[0] - S0 > 1e-3  # it moved
    assert np.abs(a.q - b.q).max() <= 1e-13 and np.abs(a.z - b.z).max() <= 1e-8 * PA0
    # a whole run, its error estimate included, is the compiled cylinder's
    ra, rb = (simulate(x, q0, np.zeros(1), (0.0, 0.06), np.linspace(0, 0.06, 7),
                       method="generalized_alpha", step=1e-3, progress=False, rtol=1e-4,
                       atol=1e-7) for x in (system, twins))
    assert rb.state_names == ("lift.p_a", "lift.p_b")
    assert (ra.verdict, ra.message) == (rb.verdict, rb.message)
    assert np.abs(ra.q - rb.q).max() < 1e-13 and np.abs(ra.states - rb.states).max() < 1e-6


@dataclass(frozen=True)
class Viscous(ForceElement):
    """A user's element: viscous drag c q' on every coordinate."""
    name: str
    c: float = 0.3
    fail_after: float = np.inf  # s: raise ValueError from then on (a failed evaluation)
    refuse: bool = False  # raise ConfigError (not an evaluation failure)

    def _force(self, system, tree, q, qd, t):
        if t > self.fail_after:
            raise ValueError("no drag table beyond this time")
        if self.refuse:
            raise ConfigError(f"force element '{self.name}': refused")
        return -self.c * qd

    def loads(self, system, tree, q, qd, t):
        return ()


def test_a_users_own_element_runs_in_the_compiled_step_and_says_so(caplog):
    s, q0, qd0 = _flexible_four_bar()
    s2 = System(s.mechanism, s.bodies, s.gravity, forces=(Viscous("drag"),))
    with caplog.at_level("INFO", logger="pipeline.solver.dae_data"):
        assert isinstance(stepper(ConstrainedSystem(s2)), CompiledStepper)
    assert "['drag'] have no compiled form" in caplog.text
    caplog.clear()
    with caplog.at_level("INFO", logger="pipeline.solver.dae_data"):
        r = simulate(s2, q0, qd0, (0.0, 0.05), method="generalized_alpha", step=1e-3,
                     progress=False, rtol=1e-4, atol=1e-6)  # the error a 1 ms step meets
    # once per run: its check at twice the step does not say it again
    assert caplog.text.count("have no compiled form") == 1
    assert r.verdict == "ok", r.report
    # the drag dissipates: the energy balance carries its power
    assert r.energies["dissipated"][-1] > 1e-3


def test_a_users_element_that_fails_to_evaluate_fails_the_step_and_other_errors_propagate():
    s, q0, qd0 = _flexible_four_bar()
    failing = System(s.mechanism, s.bodies, s.gravity,
                     forces=(Viscous("drag", fail_after=0.02),))
    r = simulate(failing, q0, qd0, (0.0, 0.05), method="generalized_alpha", step=1e-3,
                 progress=False, rtol=1e-4, atol=1e-6)
    assert r.verdict == "partial" and 0.019 < r.t[-1] <= 0.021, (r.verdict, r.t[-1])
    assert "could not be evaluated" in r.message, r.message
    refusing = System(s.mechanism, s.bodies, s.gravity, forces=(Viscous("drag", refuse=True),))
    with pytest.raises(ConfigError, match="'drag': refused"):
        stepper(ConstrainedSystem(refusing)).index1(0.0, q0, qd0, 1e-10)
    r = simulate(refusing, q0, qd0, (0.0, 0.05), method="generalized_alpha", step=1e-3,
                 progress=False)
    assert r.verdict == "partial" and "force element 'drag': refused" in r.message


def test_a_callback_entry_lives_as_long_as_its_compiled_data():
    import gc

    from pipeline.dynamics.forces import python_elements as P

    s, _, _ = _flexible_four_bar()
    s2 = System(s.mechanism, s.bodies, s.gravity, forces=(Viscous("drag"),))
    gc.collect()  # entries of earlier tests' data still waiting for the collector
    before = len(P._LIVE)
    run = stepper(ConstrainedSystem(s2))
    key = int(run.data.forces.ints[0, 0])
    assert run.data.forces.kind[0] == P.PYTHON_KIND and key in P._LIVE
    del run
    gc.collect()
    assert key not in P._LIVE and len(P._LIVE) == before
