"""Every built-in force element's physics is written once, compiled; its methods (and
statics, linearisation, kinetostatics and the energies through ``System.compiled_forces``)
evaluate those kernels. Here each kind's compiled evaluation equals the numpy oracle
(tests/dynamics/forces_numpy.py) at random states: generalized force, its non-conservative
part, potential energy, physical loads and state rates."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "solver"))
import forces_numpy as oracle
from eom_models import flexible_four_bar

from pipeline.core.errors import ConfigError
from pipeline.dynamics import System
from pipeline.dynamics.equations import equation_terms, state_rates
from pipeline.dynamics.forces import (
    FollowerForce,
    HydraulicCylinder,
    JointForce,
    JointSpringDamper,
    LineForce,
    PointForce,
    SpringDamper,
    TableSpringDamper,
    Torque,
)
from pipeline.dynamics.forces.hydraulics import PID
from pipeline.dynamics.statics import static_forces
from pipeline.kinematics import assemble, evaluate_tree
from pipeline.kinematics.drivers import SmoothStep

RAMP = SmoothStep(0.0, 0.05, 0.2, 1.0)
CYL = {"bore": 0.05, "rod": 0.03, "stroke": 1.5, "length_retracted": 0.5,
       "supply_pressure": 150e5, "nominal_flow": 1e-4, "viscous_friction": 300.0,
       "coulomb_friction": 80.0, "leakage": 1e-12}


def _elements():
    """One element of every kind (two of some), on the flexible four-bar's flexible
    coupler frame B where they can be (its elastic rotation turns the follower loads)."""
    return (
        JointSpringDamper("spring", "J2.theta", stiffness=30.0, free_value=1.0, damping=0.5),
        SpringDamper("strut", ("ground", "O4"), ("coupler", "B"), stiffness=200.0,
                     free_length=1.0, damping=2.0, preload=5.0),
        TableSpringDamper("table", ("ground", "body"), ("crank", "A"), free_length=0.5,
                          deflection=(-1.0, 0.2, 0.6, 2.0), force=(-40.0, 5.0, 30.0, 90.0),
                          damping=1.0),
        PointForce("push", ("coupler", "B"), (30.0, -20.0, 0.0), offset=(0.1, 0.05, 0.0)),
        PointForce("push_ramp", ("rocker", "B"), (3.0, -2.0, 1.0), history=RAMP),
        FollowerForce("follower", ("coupler", "B"), (0.0, 25.0, 0.0), offset=(-0.2, 0.0, 0.0),
                      history=RAMP),
        LineForce("line", ("ground", "body"), ("coupler", "B"), 15.0),
        LineForce("line_ramp", ("ground", "O4"), ("crank", "A"), -10.0, history=RAMP),
        Torque("torque", ("coupler", "B"), (0.0, 0.0, 4.0)),
        Torque("follower_torque", ("rocker", "B"), (0.5, -0.2, -3.0), follower=True,
               history=RAMP),
        JointForce("motor", "J1.theta", 2.0),
        JointForce("motor_ramp", "J1.theta", -1.5, history=RAMP),
        HydraulicCylinder("valve", ("ground", "O4"), ("coupler", "B"), command=0.5, **CYL),
        HydraulicCylinder("pumped", ("ground", "body"), ("rocker", "B"), command=RAMP,
                          pump_flow=2e-4, relief_pressure=160e5, spool_frequency=30.0,
                          spool_overlap=0.05, end_stiffness=1e6, end_damping=0.1, **CYL),
        HydraulicCylinder("controlled", ("ground", "O4"), ("crank", "A"),
                          command=PID(RAMP, kp=2.0, ki=5.0, kd=0.1, measured="marker:coupler.B:y",
                                      feedforward=0.3), spool_time_constant=0.02,
                          counterbalance={"side": "b", "setting": 80e5, "pilot_ratio": 3.0},
                          pump_flow=1e-4, relief_pressure=150e5, **CYL),
        HydraulicCylinder("lagged", ("ground", "body"), ("coupler", "B"), command=-0.3,
                          counterbalance={"side": "a", "setting": 60e5, "pilot_ratio": 4.0,
                                          "time_constant": 0.03,
                                          "closing_time_constant": 0.01}, **CYL),
        HydraulicCylinder("sprung", ("ground", "O4"), ("rocker", "B"), command=RAMP,
                          counterbalance={"side": "b", "setting": 50e5, "pilot_ratio": 3.0,
                                          "spool_frequency": 20.0, "spool_damping": 0.4},
                          spool_frequency=40.0, **CYL),
    )


def _state(seed=3):
    base = flexible_four_bar(n_modes=2).system
    s = System(base.mechanism, base.bodies, base.gravity, forces=_elements())
    rng = np.random.default_rng(seed)
    n = s.mechanism.n
    q = assemble(s.mechanism, s.mechanism.q_initial).q + 0.01 * rng.standard_normal(n)
    qd = rng.standard_normal(n)
    z0 = s.initial_states()
    z = z0 + s.state_scales() * rng.uniform(0.5, 20.0, z0.size)
    return s, q, qd, z


def _close(a, b, tol=1e-12):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    assert np.abs(a - b).max(initial=0.0) <= tol * (1.0 + np.abs(b).max(initial=0.0))


@pytest.mark.parametrize("t", [0.0, 0.13, 0.4])
def test_every_kind_equals_its_numpy_oracle(t):
    s, q, qd, z = _state()
    tree = evaluate_tree(s.mechanism, q, qd)
    for f in s.forces:
        own = s.states_of(f, z)
        Q, Qnc = oracle.force(f, s, tree, q, qd, t, *own)
        _close(f.generalized_force(s, tree, q, qd, t, *own), Q)
        _close(f.nonconservative_force(s, tree, q, qd, t, *own), Qnc)
        assert abs(f.potential_energy(s, tree, q) - oracle.potential(f, s, tree, q)) \
            <= 1e-12 * (1.0 + abs(oracle.potential(f, s, tree, q)))
        got, ref = f.loads(s, tree, q, qd, t, *own), oracle.loads(f, s, tree, q, qd, t, *own)
        assert [ld.link for ld in got] == [ld.link for ld in ref], f.name
        for a, b in zip(got, ref, strict=True):
            for x in ("point", "force", "torque"):
                _close(getattr(a, x), getattr(b, x))
        if f.STATES:
            _close(f.state_rates(s, tree, q, qd, t, own[0]),
                   oracle.rates(f, s, tree, q, qd, t, own[0]))
    # the system's sums (the equations of motion, statics) are the elements'
    terms = equation_terms(s, q, qd, t, z=z)
    refs = [oracle.force(f, s, tree, q, qd, t, *s.states_of(f, z)) for f in s.forces]
    _close(terms.Q_forces, sum(r[0] for r in refs))
    _close(terms.Q_nonconservative - terms.Q_damping, sum(r[1] for r in refs))
    _close(state_rates(s, q, qd, t, z),
           np.concatenate([oracle.rates(f, s, tree, q, qd, t, z[sl])
                           for f, sl in s.state_slices]))


def test_an_element_outside_the_system_is_evaluated_on_its_own():
    s, q, qd, _ = _state()
    tree = evaluate_tree(s.mechanism, q, qd)
    alone = SpringDamper("alone", ("ground", "body"), ("rocker", "B"), stiffness=50.0,
                         free_length=0.3, damping=1.0)
    cyl = HydraulicCylinder("other", ("ground", "body"), ("coupler", "B"), command=-0.4, **CYL)
    _close(alone.generalized_force(s, tree, q, qd, 0.1),
           oracle.force(alone, s, tree, q, qd, 0.1)[0])
    zc = np.array([40e5, 70e5])
    _close(cyl.generalized_force(s, tree, q, qd, 0.1, zc),
           oracle.force(cyl, s, tree, q, qd, 0.1, zc)[0])
    _close(cyl.state_rates(s, tree, q, qd, 0.1, zc), oracle.rates(cyl, s, tree, q, qd, 0.1, zc))


def test_a_cylinders_state_layout_is_the_one_its_compiled_rates_use():
    """The layout (names, units, scales) is stated once (state_layout); the compiled
    kernel counts the same states from the element's parameters, and the start values
    come in the same number, for every combination the machine above has."""
    from pipeline.dynamics.forces.hydraulics import HydraulicCylinder, _state_count

    seen = set()
    for f in _elements():
        if not isinstance(f, HydraulicCylinder):
            continue
        n = len(f.state_layout())
        assert n == _state_count(f.parameters()) == len(f.initial_states()) \
            == len(f.state_scales()) == len(f.STATE_UNITS) == len(f.STATES)
        seen.add(f.STATES)
    assert ("p_a", "p_b", "p_s", "x_v", "v_v") in seen
    assert ("p_a", "p_b", "p_s", "p_c", "x_v", "pid") in seen
    assert ("p_a", "p_b", "p_c", "a_c") in seen
    assert ("p_a", "p_b", "p_c", "a_c", "v_c", "x_v", "v_v") in seen


def test_an_analysis_without_states_names_the_element_that_has_them():
    s, q, _, _ = _state()
    with pytest.raises(ConfigError, match="force element 'valve'.*states of its own"):
        static_forces(s, q)


def test_a_users_subclass_of_a_built_in_is_its_own_element():
    """A subclass is not the built-in class: it has no compiled form and says what it
    lacks; given a _force it is evaluated by it."""

    @dataclass(frozen=True)
    class Bare(SpringDamper):
        pass

    @dataclass(frozen=True)
    class Doubled(SpringDamper):
        def _force(self, system, tree, q, qd, t):
            return 2.0 * oracle.force(SpringDamper(self.name, self.marker_a, self.marker_b,
                                                   self.stiffness, self.free_length),
                                      system, tree, q, qd, t)[0]

    s, q, qd, _ = _state()
    tree = evaluate_tree(s.mechanism, q, qd)
    kw = {"marker_a": ("ground", "O4"), "marker_b": ("coupler", "B"), "stiffness": 200.0,
          "free_length": 1.0}
    with pytest.raises(NotImplementedError, match="force element 'bare' .*no compiled form"):
        Bare("bare", **kw).generalized_force(s, tree, q, qd, 0.0)
    ref = oracle.force(SpringDamper("x", **kw), s, tree, q, qd, 0.0)[0]
    _close(Doubled("doubled", **kw).generalized_force(s, tree, q, qd, 0.0), 2.0 * ref)


def test_a_machine_without_force_elements_calls_no_force_kernel(monkeypatch):
    """Its force sums are zeros without the elements' compiled dispatchers, which a fresh
    machine's first run would otherwise compile (22 s of the main job's first run here,
    in each case worker) to add nothing."""
    import pipeline.dynamics.forces.compiled as C

    base = flexible_four_bar(n_modes=2).system
    s = System(base.mechanism, base.bodies, base.gravity)
    q = assemble(s.mechanism, s.mechanism.q_initial).q
    qd = np.linspace(-1.0, 1.0, q.size)

    def compiled(*args):
        raise AssertionError("a force kernel was called")

    for name in ("generalized_forces", "potential", "state_rates"):
        monkeypatch.setattr(C, name, compiled)
    tree = evaluate_tree(s.mechanism, q, qd)
    Q, Qnc = s.compiled_forces.forces(tree, q, qd, 0.3)
    assert Q.shape == Qnc.shape == (q.size,) and not Q.any() and not Qnc.any()
    assert s.compiled_forces.potential(tree, q) == 0.0
    assert s.compiled_forces.rates(tree, q, qd, 0.3, np.zeros(0)).shape == (0,)
    terms = equation_terms(s, q, qd, 0.3)
    assert not terms.Q_forces.any()
