"""The public stepping API (pipeline.solver.simulator.Simulator): a run in many calls is the
same run as one ``simulate`` call, inputs set from outside act as declared, a discrete
controller closes a loop around a machine, and the state can be saved and restored."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
from eom_models import flexible_four_bar

from pipeline.core.errors import ConfigError, SolverError
from pipeline.dynamics import static_equilibrium
from pipeline.dynamics.forces.loads import JointForce
from pipeline.dynamics.forces.springs import JointSpringDamper
from pipeline.kinematics.drivers import Ramp
from pipeline.solver import simulate
from pipeline.solver.simulator import Simulator

H, DT, T_END = 1e-3, 0.01, 0.5


@pytest.fixture(scope="module")
def four_bar():
    """The four-bar with a flexible coupler (two modes, made 100x stiffer than the test
    model so that it bends within the linear range) on a closed loop, under gravity, its
    crank J2 free, its start on the loop."""
    system = flexible_four_bar(n_modes=2).system
    coupler = system.bodies["coupler"]
    system = replace(system, bodies={**system.bodies, "coupler": replace(
        coupler, stiffness=100.0 * coupler.stiffness)})
    q0 = np.zeros(system.mechanism.n)
    q0[:4] = [1.2, 0.35 - 1.2, 1.5 - 0.35, 1.5]
    r = simulate(system, q0, np.zeros_like(q0), (0.0, 1e-3), method="generalized_alpha",
                 step=1e-3, progress=False, error_estimate=False)
    return system, r.q[0]


TOL = {"rtol": 1e-4, "atol": 1e-6}


def _simulate(system, q0, **kw):
    te = np.linspace(0.0, T_END, round(T_END / DT) + 1)
    return simulate(system, q0, np.zeros_like(q0), (0.0, T_END), te,
                    method="generalized_alpha", step=H, progress=False, **TOL, **kw)


def test_many_calls_are_one_simulate_call(four_bar):
    """Same step, same output times: every recorded quantity equal to 1e-12, and the
    same verdict (without the error estimates, which differ by design: see below)."""
    system, q0 = four_bar
    ref = _simulate(system, q0, error_estimate=False)
    sim = Simulator(system, q0, step=H, error_estimate=False, **TOL)
    while sim.t < T_END - 1e-12:
        sim.step(DT)
    r = sim.result()
    assert r.t.shape == ref.t.shape and np.allclose(r.t, ref.t, rtol=0, atol=1e-12)
    for a, b in ((r.q, ref.q), (r.qd, ref.qd), (r.qdd, ref.qdd),
                 (r.multipliers, ref.multipliers)):
        assert np.abs(a - b).max() <= 1e-12 * max(1.0, np.abs(b).max())
    for key in ref.energies:
        assert np.abs(r.energies[key] - ref.energies[key]).max() < 1e-12 * \
            max(1.0, np.abs(ref.energies["kinetic"]).max())
    assert np.abs(ref.q[-1] - ref.q[0]).max() > 0.1  # it moved: the comparison means something
    assert (r.verdict, r.warnings, r.n_steps) == (ref.verdict, ref.warnings, ref.n_steps)
    assert r.n_steps == 500 and sim.error_ratio is None


def _error(r, ref, i):
    keep = np.isin(np.round(ref.t, 9), np.round(r.t, 9))
    return np.abs(r.q[:, i] - ref.q[keep, i]).max()


@pytest.mark.parametrize("dt", [DT, H])
def test_the_error_estimate_of_the_calls_bounds_the_error(four_bar, dt):
    """The calls' accumulated estimate (each call again at twice the step, or at half
    the step for calls of one step) against the error of the run itself, measured
    against the same run at 1/16 of the step, both over the tolerance: the free
    four-bar carries its phase errors on, so the sum of the calls' errors reads low for
    many short calls (0.8x over 500 calls of one step) and high for calls of ten steps
    (1.7x); the replay of the inputs (none depend on the state here) bounds it."""
    from pipeline.solver.step_error import scaled_error

    system, q0 = four_bar
    ref = simulate(system, q0, np.zeros_like(q0), (0.0, T_END),
                   np.linspace(0.0, T_END, round(T_END / H) + 1), method="generalized_alpha",
                   step=H / 16, progress=False, error_estimate=False, **TOL)
    sim = Simulator(system, q0, step=H, **TOL)
    while sim.t < T_END - 1e-12:
        sim.step(dt)
    r = sim.result()
    keep = np.isin(np.round(ref.t, 9), np.round(r.t, 9))
    mech = system.mechanism
    true = scaled_error(r, np.abs(r.q - ref.q[keep]), np.arange(mech.n), TOL["rtol"],
                        TOL["atol"], mech.coordinate_units, mech.modal_index)["error_ratio"]
    estimate = r.step_stats["error_ratio"]
    assert estimate == pytest.approx(sim.error_ratio)
    assert 0.7 * true <= estimate <= 30 * true, (true, estimate)
    assert true > 1.0 and r.verdict == "suspect"  # above the tolerance: flagged
    assert true <= sim.result(replay=True).step_stats["error_ratio"] <= 30 * true


def test_a_driven_coordinate_set_from_outside_follows_its_values(four_bar):
    """The crank driven by a ramp that starts at 0.1 s, once as a driver and once as an
    input given the ramp's values at each call (a linear motion: the first-order hold is
    exact). There the rate jumps: both start the method afresh from the velocities the
    jump's impulse gives (simulate at the driver's break, the Simulator at the input's),
    so they are the same run, driver torque included. The impulse sets the coupler's
    stiff modes ringing, which 1 ms does not resolve: the run's own error estimate says
    so, and bounds its error against the same run at 1/16 of the step."""
    from pipeline.solver.step_error import scaled_error

    system, q0 = four_bar
    ramp = Ramp(t0=0.1, slope=2.0, v0=float(q0[0]))
    driven = replace(system, drivers={"J2.theta": ramp})
    ref = _simulate(driven, q0)
    fine = simulate(driven, q0, np.zeros_like(q0), (0.0, T_END), ref.t,
                    method="generalized_alpha", step=H / 16, progress=False,
                    error_estimate=False, **TOL)
    sim = Simulator(driven, q0, step=H, inputs=["J2.theta"], **TOL)
    assert sim.inputs == {"J2.theta": pytest.approx(q0[0])}
    while sim.t < T_END - 1e-12:
        sim.step(DT, {"J2.theta": ramp.value(sim.t + DT)})
    r = sim.result()
    kink = np.isclose(r.t, 0.1)
    assert np.abs(r.q - ref.q).max() < 1e-10
    assert np.abs(r.driver_forces - ref.driver_forces).max() < 1e-8 * \
        np.abs(ref.driver_forces).max()
    # at the kink itself the rate reported is the one arriving there
    assert r.qd[kink, 0] == 0.0 and ref.qd[kink, 0] == 0.0
    assert np.abs(r.q[:, 0] - ramp.value(r.t)).max() < 1e-12
    mech = system.mechanism
    true = scaled_error(ref, np.abs(ref.q - fine.q), np.arange(mech.n), TOL["rtol"],
                        TOL["atol"], mech.coordinate_units, mech.modal_index)["error_ratio"]
    assert true <= ref.step_stats["error_ratio"] <= 4 * true and ref.verdict == "suspect"


def _pd_run(system, q0, period, kp, kd, goal, t_end, step=H, **kw):
    sim = Simulator(system, q0, step=step, inputs={"motor": 0.0}, **kw)
    i = system.mechanism.index("J2.theta")
    while sim.t < t_end - 1e-12:
        sim.step(period, {"motor": -kp * (sim.q[i] - goal) - kd * sim.qd[i]})
    return sim


def test_a_discrete_pd_controller_drives_the_machine_from_outside(four_bar):
    """A PD torque on the crank computed outside at each sample (zero-order hold): it
    settles where the static equilibrium with the equivalent spring does, and it tends to
    the continuous spring-damper's motion at first order in the sample period (the hold's
    delay of half a period; integrated at the continuous run's step, so that only the hold
    differs)."""
    system, q0 = four_bar
    kp, kd, goal = 400.0, 40.0, 1.0
    motor = JointForce("motor", "J2.theta", force=1.0)
    controlled = replace(system, forces=(*system.forces, motor))
    spring = replace(system, forces=(*system.forces, JointSpringDamper(
        "pd", "J2.theta", stiffness=kp, free_value=goal, damping=kd)))
    i = system.mechanism.index("J2.theta")

    settled = _pd_run(controlled, q0, 2e-3, kp, kd, goal, 3.0)
    static = static_equilibrium(spring, settled.q)
    assert static.success
    assert abs(settled.q[i] - static.q[i]) < 1e-5
    assert abs(static.q[i] - goal) > 1e-3  # gravity holds it off the goal: a real check

    t_end = 0.4
    te = np.linspace(0.0, t_end, 11)  # multiples of every sample period
    cont = simulate(spring, q0, np.zeros_like(q0), (0.0, t_end), te,
                    method="generalized_alpha", step=2.5e-4, progress=False)
    errors = []
    for period in (4e-3, 2e-3, 1e-3):
        sim = _pd_run(controlled, q0, period, kp, kd, goal, t_end, step=2.5e-4)
        r = sim.result()
        keep = np.isin(np.round(r.t, 9), np.round(te, 9))
        errors.append(np.abs(r.q[keep, i] - cont.q[:, i]).max())
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((rates > 0.8) & (rates < 1.3)), (errors, rates)
    assert errors[-1] < 2e-3


def test_inputs_that_jump_at_every_call_keep_the_method_second_order():
    """The rigid four-bar under a PD torque sampled every 2 ms (a jump of the input at
    every call): against the same loop at a step of 10 us the crank angle converges at
    second order in the step (each jump restarts the method; without the restart it
    was first order, 10x the error at 1 ms)."""
    system = flexible_four_bar(n_modes=0).system
    q0 = np.zeros(system.mechanism.n)
    q0[:4] = [1.2, 0.35 - 1.2, 1.5 - 0.35, 1.5]
    q0 = simulate(system, q0, np.zeros_like(q0), (0.0, 1e-3), method="generalized_alpha",
                  step=1e-3, progress=False, error_estimate=False).q[0]
    motor = JointForce("motor", "J2.theta", force=1.0)
    plant = replace(system, forces=(motor,))
    runs = [_pd_run(plant, q0, 2e-3, 400.0, 40.0, 1.0, 0.3, step=h, **TOL).result()
            for h in (1e-5, 1e-3, 5e-4, 2.5e-4)]
    errors = [np.abs(r.q[:, 0] - runs[0].q[:, 0]).max() for r in runs[1:]]
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(rates > 1.7), (errors, rates)
    # the calls' estimate at 1 ms is above the error (0.75 urad) and within the tolerance
    tol = TOL["atol"] + TOL["rtol"] * np.abs(runs[1].q[:, 0]).max()
    assert errors[0] / tol <= runs[1].step_stats["error_ratio"] <= 1.0
    assert runs[1].verdict == "ok", runs[1].warnings


def test_state_saved_and_restored_continues_the_same(four_bar):
    """Rewind to a saved state: the continuation repeats the first one bit for bit (after
    the iteration matrix is rebuilt, which does not change a converged step), and the
    history after the saved time is dropped."""
    system, q0 = four_bar
    motor = JointForce("motor", "J2.theta", force=1.0)
    sim = Simulator(replace(system, forces=(motor,)), q0, step=H, inputs=["motor"])
    sim.step(0.05, {"motor": 2.0})
    saved = sim.state
    sim.step(0.05, {"motor": -1.0})
    first = sim.q
    sim.set_state(saved)
    assert sim.t == pytest.approx(0.05) and sim.inputs == {"motor": 2.0}
    assert sim.result().t.size == 2
    sim.step(0.05, {"motor": -1.0})
    assert np.abs(sim.q - first).max() < 1e-9
    assert sim.result().t.size == 3


def test_a_copy_continues_as_the_original_does(four_bar):
    """Simulator.copy: the same machine and inputs at the original's state; the same calls
    from there give the same motion, and the original is left as it was."""
    system, q0 = four_bar
    motor = JointForce("motor", "J2.theta", force=1.0)
    sim = Simulator(replace(system, forces=(motor,)), q0, step=H, inputs=["motor"])
    sim.step(0.05, {"motor": 2.0})
    twin = sim.copy()
    assert twin.t == sim.t and twin.inputs == {"motor": 2.0}
    assert np.array_equal(twin.q, sim.q) and np.array_equal(twin.qd, sim.qd)
    for x in (sim, twin):
        x.step(0.05, {"motor": -1.0})
    assert np.abs(twin.q - sim.q).max() < 1e-9 and np.abs(twin.qd - sim.qd).max() < 1e-7
    assert sim.result().t.size == 3 and twin.error_ratio is None  # no estimate of its own


def test_bad_calls_say_what_was_expected(four_bar):
    system, q0 = four_bar
    sim = Simulator(system, q0, step=H)
    with pytest.raises(ConfigError, match="'motor' was not declared"):
        sim.step(0.01, {"motor": 1.0})
    with pytest.raises(ConfigError, match="dt: expected a time > 0 s"):
        sim.step(0.0)
    with pytest.raises(ConfigError, match="expected the name of a force element"):
        Simulator(system, q0, step=H, inputs=["nothing"])
    with pytest.raises(ConfigError, match="step: expected a fixed step"):
        Simulator(system, q0, step=float("nan"))
    motor = JointForce("motor", "J2.theta")
    sim = Simulator(replace(system, forces=(motor,)), q0, step=H, inputs=["motor"])
    with pytest.raises(ConfigError, match="'motor': expected a finite number"):
        sim.step(0.01, {"motor": float("inf")})
    assert sim.t == 0.0


def test_a_step_that_cannot_be_done_leaves_the_state_where_it_was(four_bar):
    """A torque so large that Newton fails even at a tiny step: SolverError, and the
    simulator still at the start of the call (a co-simulation master can retry)."""
    system, q0 = four_bar
    motor = JointForce("motor", "J2.theta")
    sim = Simulator(replace(system, forces=(motor,)), q0, step=H, inputs=["motor"])
    sim.step(0.01, {"motor": 1.0})
    before = sim.q
    with pytest.raises(SolverError, match=r"Simulator.step from t = 0.01 s"):
        sim.step(0.01, {"motor": 1e30})
    assert sim.t == pytest.approx(0.01) and np.array_equal(sim.q, before)
    assert sim.inputs == {"motor": 1.0}
    sim.step(0.01)
    assert sim.t == pytest.approx(0.02)


def test_a_failed_check_loses_the_estimate_not_the_call(four_bar, monkeypatch):
    """When a call's check run (the call again at another step) fails, the user's call
    stands; the estimate is lost from there on and the result says the run is not known to
    be within its tolerance (it used to fail the call)."""
    system, q0 = four_bar
    sim = Simulator(system, q0, step=H, **TOL)
    sim.step(DT)
    assert sim.error_ratio is not None
    monkeypatch.setattr(Simulator, "_check_call",
                        lambda self, *a: "the check at 0.002 s steps failed: Newton")
    sim.step(DT)
    assert sim.t == pytest.approx(2 * DT) and sim.error_ratio is None
    monkeypatch.undo()
    sim.step(DT)
    r = sim.result()
    assert r.verdict == "suspect" and "error_ratio" not in r.step_stats
    (w,) = r.warnings
    assert "could not be estimated (at t = 0.01 s the check at 0.002 s steps failed" in w


def test_simulate_says_when_its_estimate_failed(four_bar, monkeypatch):
    """The same for simulate: a fixed-step run whose run at twice the step fails is not
    ``ok`` (it was, silently, without an estimate)."""
    from pipeline.solver import dae

    run_dae = dae.run_dae

    def coarse_fails(*a, estimate=True, **kw):
        r = run_dae(*a, estimate=estimate, **kw)
        return r if estimate else replace(r, success=False, message="Newton failed")

    monkeypatch.setattr(dae, "run_dae", coarse_fails)
    system, q0 = four_bar
    r = _simulate(system, q0)
    assert r.success and r.verdict == "suspect" and "error_ratio" not in r.step_stats
    assert any("could not be estimated (the run at twice the step failed: Newton failed)"
               in w for w in r.warnings), r.warnings
