"""A PID controller commanding a hydraulic cylinder's valve (issue 27 item 3,
pipeline.dynamics.forces.hydraulics.PID): its integral term a state of the element,
integrated in the generalised-alpha step with the motion and the pressures.

References built here, independent of the package's equations: the 500 kg lift of
``test_hydraulic_cylinder.py`` with the controller written by hand into its ODE (five
states: position, velocity, two pressures, the integral term), with the clipped output
and the back-calculation written out, integrated by scipy's Radau at 1e-11.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_hydraulic_cylinder import (
    AA,
    AB,
    BETA,
    DPL,
    DPNOM,
    MASS,
    PA0,
    PB0,
    PS,
    QNOM,
    S0,
    STROKE,
    VA0,
    VB0,
    G,
    _lift,
)

from pipeline.core.errors import ConfigError
from pipeline.dynamics import System
from pipeline.dynamics.equations import state_rates
from pipeline.dynamics.forces.hydraulics import PID
from pipeline.kinematics.drivers import SmoothStep
from pipeline.solver import simulate

VISCOUS = 1e4  # N s/m: seal friction, so that the oil spring's ringing settles


def _reference(pid: PID, t_end, te):
    """The lift under the controller, in its own five states (module docstring)."""
    kv = QNOM / np.sqrt(DPNOM)
    lo, hi = pid.output_limits
    ti = pid.kp / pid.ki if pid.ki else np.inf
    tt = pid.tracking_time or (np.sqrt(ti * pid.kd / pid.kp) if pid.kd else ti)

    def orifice(dp):
        return dp / (dp * dp + DPL * DPL) ** 0.25

    def rhs(t, y):
        s, v, pa, pb, xi = y
        measured, rate = (pa, 0.0) if pid.measured == "p_a" else (s, v)
        e = pid.reference.value(t) - measured
        w = pid.feedforward * pid.reference.rate(t) + pid.kp * e + xi - pid.kd * rate
        u = min(max(w, lo), hi)
        qa = kv * (max(u, 0) * orifice(PS - pa) - max(-u, 0) * orifice(pa))
        qb = kv * (max(-u, 0) * orifice(PS - pb) - max(u, 0) * orifice(pb))
        return [v, (pa * AA - pb * AB - VISCOUS * v) / MASS - G, BETA / (VA0 + AA * s) * (qa - AA * v),
                BETA / (VB0 + AB * (STROKE - s)) * (qb + AB * v), pid.ki * e + (u - w) / tt]

    sol = solve_ivp(rhs, (0.0, t_end), [S0, 0.0, PA0, PB0, 0.0], method="Radau", t_eval=te,
                    rtol=1e-11, atol=[1e-13, 1e-12, 1e-4, 1e-4, 1e-12], max_step=1e-3)
    return sol.y.T


def _run(system, te, step, **kw):
    return simulate(system, np.array([S0]), np.zeros(1), (0.0, te[-1]), te,
                    method="generalized_alpha", step=step, progress=False,
                    **{"rtol": 1e-5, "atol": 1e-8, **kw})


@pytest.mark.parametrize("case", ["tracking", "saturating", "feedforward"])
def test_the_controlled_lift_is_the_hand_written_model(case):
    """Tracking: a 5 cm quintic move in 0.3 s, the output within its limits. Saturating: a
    20 cm step asked in 20 ms, the valve driven to its 0.6 limit and the integral held by
    the back-calculation. The stroke, pressures and integral term match the reference at
    second order in the step, and the mass ends near the reference."""
    if case == "tracking":
        pid = PID(SmoothStep(0.0, 0.3, S0, S0 + 0.05), kp=20.0, ki=40.0, kd=0.5)
    elif case == "feedforward":  # k_ff ~ A_a / Q_u: the valve opens for the move itself
        pid = PID(SmoothStep(0.0, 0.3, S0, S0 + 0.05), kp=5.0, feedforward=3.2)
    else:
        pid = PID(SmoothStep(0.0, 0.02, S0, S0 + 0.2), kp=30.0, ki=30.0,
                  output_limits=(-0.6, 0.6))
    system, _ = _lift(pid, viscous_friction=VISCOUS)
    assert system.state_names == ("lift.p_a", "lift.p_b", "lift.pid")
    te = np.linspace(0.0, 2.0, 101)
    ref = _reference(pid, te[-1], te)
    errors = []
    for h in (1e-3, 5e-4, 2.5e-4):
        r = _run(system, te, h)
        assert r.success, r.message
        errors.append((np.abs(r.q[:, 0] - ref[:, 0]).max(),
                       np.abs(r.states[:, :2] - ref[:, 2:4]).max(),
                       np.abs(r.states[:, 2] - ref[:, 4]).max()))
    stroke, pressure, integral = np.array(errors).T
    # m, Pa (of ~5 MPa), valve-command units; the clip's corners cost the saturating run
    # some of its order (and its error estimate calls it suspect at rtol 1e-5)
    bound = {"tracking": (1e-8, 10.0, 1e-7), "saturating": (1e-6, 2e3, 1e-6),
             "feedforward": (5e-8, 100.0, 1e-7)}[case]
    assert stroke[-1] < bound[0] and pressure[-1] < bound[1] and integral[-1] < bound[2], \
        errors
    for e in (stroke, pressure):
        assert np.all(np.log2(e[:-1] / e[1:]) > 1.6), errors
    goal = pid.reference.value(te[-1])
    if case == "feedforward":  # the same loop without it lags the move several times more
        lag = np.abs(r.q[:, 0] - [pid.reference.value(t) for t in te]).max()
        slow = _run(_lift(replace(pid, feedforward=0.0), viscous_friction=VISCOUS)[0], te,
                    2.5e-4)
        lag_p = np.abs(slow.q[:, 0] - [pid.reference.value(t) for t in te]).max()
        assert lag < 0.3 * lag_p, (lag, lag_p)
    elif case == "tracking":
        # a valve-fed cylinder integrates its flow: the integral term overshoots a little
        # and returns slowly (0.2 mm off after 2 s)
        assert abs(ref[-1, 0] - goal) < 5e-4 and abs(r.q[-1, 0] - goal) < 5e-4
    else:  # the limit held the valve, and the back-calculation the integral: without it
        # (a tracking time of 1e6 s) the integral winds up and the mass overshoots 8x more
        u = pid.kp * (goal - ref[:, 0]) + ref[:, 4] - pid.kd * ref[:, 1]
        assert u.max() > 0.6
        wound = _run(_lift(replace(pid, tracking_time=1e6), viscous_friction=VISCOUS)[0],
                     te, 1e-3)
        over, over_wound = r.q[:, 0].max() - goal, wound.q[:, 0].max() - goal
        assert 0.005 < over < 0.015 and over_wound > 0.08, (over, over_wound)


def test_a_pressure_loop_is_the_hand_written_model_and_holds_its_reference():
    """The piston side's pressure raised 20 bar by a PI loop: the pressure settles on its
    reference (integral action) while the mass, pushed by more than its weight, rises
    against the rod side's outflow (a pressure loop holds a force, not a position)."""
    pid = PID(SmoothStep(0.0, 0.1, PA0, PA0 + 20e5), kp=2e-6, ki=2e-5, measured="p_a")
    system, _ = _lift(pid, viscous_friction=VISCOUS)
    te = np.linspace(0.0, 1.0, 51)
    ref = _reference(pid, te[-1], te)
    errors = []
    for h in (5e-4, 2.5e-4):
        r = _run(system, te, h)
        assert r.success, r.message
        errors.append((np.abs(r.q[:, 0] - ref[:, 0]).max(),
                       np.abs(r.states[:, :2] - ref[:, 2:4]).max()))
    (s1, _), (s2, p2) = errors
    assert s2 < 1e-7 and p2 < 100.0 and s1 / s2 > 3.0, errors  # m; Pa of ~5 MPa
    assert abs(r.states[-1, 0] - (PA0 + 20e5)) < 1e3
    assert r.qd[-1, 0] > 0.01 and r.q[-1, 0] > S0 + 0.01


def test_a_derivative_term_on_a_pressure_is_refused():
    with pytest.raises(ConfigError, match="kd: a loop on the pressure p_a has no derivative"):
        PID(PA0, kp=1e-6, kd=1e-8, measured="p_a")


def test_a_controller_on_the_joint_coordinate_is_the_one_on_the_stroke():
    """The lift's stroke is its slide coordinate: measuring either runs the same machine."""
    pid = PID(SmoothStep(0.0, 0.2, S0, S0 + 0.04), kp=20.0, ki=20.0)
    te = np.linspace(0.0, 0.4, 21)
    a = _run(_lift(pid)[0], te, 1e-3)
    b = _run(_lift(replace(pid, measured="slide.d"))[0], te, 1e-3)
    assert a.verdict == b.verdict
    assert np.abs(a.q - b.q).max() < 1e-12 and np.abs(a.states - b.states).max() < 1e-4


def test_the_compiled_rates_equal_the_numpy_methods():
    from pipeline.solver import dae_kernels as K
    from pipeline.solver.dae_data import compile_dae, force_factors

    pid = PID(SmoothStep(0.0, 1.0, 0.2, 0.4), kp=8.0, ki=3.0, kd=0.2, measured="slide.d",
              output_limits=(-0.5, 0.8), feedforward=1.5)
    system, _ = _lift(pid, spool_time_constant=0.01)
    data = compile_dae(system, np.arange(1), np.zeros(0, dtype=int))
    args = (K.kin_tuple(data.kin), K.mass_tuple(data.masses), data.K, data.D,
            data.gravity4, data.w, data.forces)
    for s, v, xi in ((0.25, 0.1, 0.05), (0.1, -0.3, 0.4), (0.2, 0.0, -0.9)):
        q, qd, z = np.array([s]), np.array([v]), np.array([60e5, 20e5, 0.1, xi])
        zd = K.terms(q, qd, z, force_factors(data, [0.4])[0], *args)[6]
        assert np.abs(zd - state_rates(system, q, qd, 0.4, z)).max() <= 1e-9 * np.abs(zd).max()


def test_the_simulators_input_by_the_cylinders_name_is_the_reference():
    """From outside, the cylinder's name sets the controller's reference: holding it at
    the goal from t = 0 is the run with that constant reference."""
    from pipeline.solver.simulator import Simulator

    pid = PID(S0, kp=20.0, ki=20.0)
    system, _ = _lift(pid)
    goal = S0 + 0.03
    sim = Simulator(system, np.array([S0]), step=1e-3, inputs={"lift": goal}, rtol=1e-5,
                    atol=1e-8)
    for _ in range(50):
        sim.step(0.01, {"lift": goal})
    ours = sim.result()
    assert ours.state_names == ("lift.p_a", "lift.p_b", "lift.pid")
    direct = simulate(_lift(replace(pid, reference=goal))[0], np.array([S0]), np.zeros(1),
                      (0.0, ours.t[-1]), ours.t, method="generalized_alpha", step=1e-3,
                      progress=False, rtol=1e-5, atol=1e-8)
    assert np.abs(ours.q - direct.q).max() < 1e-12
    assert abs(ours.q[-1, 0] - goal) < 0.1 * (goal - S0)  # on its way, the oil ringing


@pytest.mark.parametrize("kw, match", [
    ({"kp": -1.0}, "kp: expected a gain >= 0"),
    ({"kp": 1.0, "output_limits": (0.5, 0.2)}, "output_limits"),
    ({"kp": 1.0, "tracking_time": 0.0}, "tracking_time"),
])
def test_a_bad_controller_is_refused_naming_its_field(kw, match):
    with pytest.raises(ConfigError, match=match):
        PID(S0, **kw)


def test_a_controller_on_an_unknown_coordinate_is_refused_naming_the_cylinder():
    system, cyl = _lift(PID(S0, kp=1.0, measured="slide.x"))
    with pytest.raises(ConfigError, match="force element 'lift': command: measured"):
        cyl.validate(system)
    assert isinstance(system, System)


def test_a_controller_on_a_marker_position_is_the_one_on_its_coordinate():
    """The lift's mass moves its body origin along ground z by its slide coordinate:
    measuring the marker's z or the coordinate runs the same machine."""
    pid = PID(SmoothStep(0.0, 0.2, S0, S0 + 0.04), kp=20.0, ki=20.0, kd=0.3)
    te = np.linspace(0.0, 0.4, 21)
    a = _run(_lift(replace(pid, measured="slide.d"))[0], te, 1e-3)
    b = _run(_lift(replace(pid, measured="marker:mass.body:z"))[0], te, 1e-3)
    assert a.verdict == b.verdict and a.success and b.success
    assert np.abs(a.q - b.q).max() < 1e-12 and np.abs(a.states - b.states).max() < 1e-4


def _arm(pid, L=2.0):
    """A 50 kg arm on a pivot (about z, gravity -y) lifted by a cylinder from a ground
    mount (0.8, -0.6) to the arm's eye 0.8 m out; its tip L m out is at height
    L sin(theta)."""
    from pipeline.dynamics import BodyMass
    from pipeline.dynamics.forces.hydraulics import HydraulicCylinder
    from pipeline.kinematics import Joint, build_mechanism, rigid_link
    from pipeline.kinematics.rotations import translation

    mech = build_mechanism(
        [rigid_link("ground", {"mount": translation([0.8, -0.6, 0.0])}),
         rigid_link("arm", {"eye": translation([0.8, 0.0, 0.0]),
                            "tip": translation([L, 0.0, 0.0])})],
        [Joint("pivot", "revolute", "ground", "body", "arm", "body", q0=[0.2])])
    cyl = HydraulicCylinder("lift", ("ground", "mount"), ("arm", "eye"), bore=0.08,
                            rod=0.04, stroke=0.8, length_retracted=0.4,
                            supply_pressure=PS, nominal_flow=QNOM, nominal_drop=DPNOM,
                            command=pid, bulk_modulus=BETA, laminar_drop=DPL,
                            initial_pressures=(PA0, PB0))
    return System(mech, {"arm": BodyMass.rigid(50.0, [1.0, 0, 0], np.eye(3))},
                  gravity=[0, -G, 0], forces=(cyl,))


def test_a_controller_on_a_marker_reads_its_height_and_rate_in_closed_form():
    """On the pivoting arm the tip's height is L sin(theta) and its rate L cos(theta)
    theta': with the output clipped, the integral term's rate k_i e + (u - v) / T_t
    carries both (v = k_p e + x_i - k_d y'); compiled and numpy rates agree."""
    from pipeline.solver import dae_kernels as K
    from pipeline.solver.dae_data import compile_dae, force_factors

    L, ref, kp, ki, kd, tt = 2.0, 0.5, 3.0, 2.0, 0.7, 0.05
    pid = PID(ref, kp=kp, ki=ki, kd=kd, measured="marker:arm.tip:y",
              output_limits=(-0.4, 0.4), tracking_time=tt)
    system = _arm(pid, L)
    data = compile_dae(system, np.arange(1), np.zeros(0, dtype=int))
    args = (K.kin_tuple(data.kin), K.mass_tuple(data.masses), data.K, data.D,
            data.gravity4, data.w, data.forces)
    clipped = 0
    for th, w, xi in ((0.3, 0.5, 0.1), (-0.1, -1.0, 0.9), (0.6, 0.0, -0.3), (0.25, 0.2, 0.0)):
        q, qd, z = np.array([th]), np.array([w]), np.array([PA0, PB0, xi])
        zd = K.terms(q, qd, z, force_factors(data, [0.0])[0], *args)[6]
        e = ref - L * np.sin(th)
        v = kp * e + xi - kd * L * np.cos(th) * w
        u = min(max(v, -0.4), 0.4)
        clipped += u != v
        assert zd[2] == pytest.approx(ki * e + (u - v) / tt, rel=1e-12, abs=1e-12)
        assert np.abs(zd - state_rates(system, q, qd, 0.0, z)).max() <= 1e-9 * np.abs(zd).max()
    assert 0 < clipped < 4  # both sides of the limit were looked at


@pytest.mark.parametrize("measured, match", [
    ("marker:arm.tip:w", "marker: expected 'link.frame:x"),
    ("marker:armtip:y", "marker: expected 'link.frame:x"),
])
def test_a_malformed_marker_measurement_is_refused(measured, match):
    with pytest.raises(ConfigError, match=match):
        PID(0.5, kp=1.0, measured=measured)


@pytest.mark.parametrize("measured, match", [
    ("marker:boom.tip:y", "link 'boom' does not exist"),
    ("marker:arm.nose:y", "frame 'nose' does not exist"),
])
def test_a_controller_on_an_unknown_marker_is_refused_naming_the_cylinder(measured, match):
    system = _arm(PID(0.5, kp=1.0, measured=measured))
    with pytest.raises(ConfigError, match=f"force element 'lift': command: measured: .*{match}"):
        system.forces[0].validate(system)
