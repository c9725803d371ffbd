"""The hydraulic cylinder (pipeline.dynamics.forces.hydraulics): the first force element
with states of its own, integrated in the generalised-alpha step with the motion.

References built here, independent of the package's equations:
- a 500 kg mass lifted vertically by the cylinder through its valve, written by hand in
  its four states (position, velocity, two pressures) with its own orifice law, integrated
  by scipy's Radau at 1e-11;
- the oil columns' spring with the valve closed: the mass rings at
  sqrt(beta (A_a^2 / V_a + A_b^2 / V_b) / m) about the equilibrium the pressures hold;
- the compiled force and pressure rates against the element's numpy methods, and the force
  against finite differences of the line's length (virtual work).
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
from eom_models import flexible_four_bar

from pipeline.core.errors import ConfigError
from pipeline.dynamics import BodyMass, System, equation_terms
from pipeline.dynamics.equations import state_rates
from pipeline.dynamics.forces.hydraulics import HydraulicCylinder
from pipeline.kinematics import Joint, assemble, build_mechanism, rigid_link
from pipeline.kinematics.drivers import SmoothStep
from pipeline.solver import simulate

MASS, G = 500.0, 9.81
BORE, ROD, STROKE, L0 = 0.08, 0.04, 0.5, 1.0
BETA, PS, QNOM, DPNOM, DPL = 1.0e9, 100e5, 60e-3 / 60, 35e5, 1e5
AA = np.pi / 4 * BORE ** 2
AB = AA - np.pi / 4 * ROD ** 2
VA0, VB0 = 0.1 * AA * STROKE, 0.1 * AB * STROKE
S0, PB0 = 0.2, 10e5
PA0 = (MASS * G + PB0 * AB) / AA  # the pressures that hold the mass at rest


def _translate(z):
    T = np.eye(4)
    T[2, 3] = z
    return T


def _lift(command=0.0, **kw):
    """A mass on a vertical prismatic joint (d along world z, gravity -z), its cylinder
    from a ground mount 1 m below the rail's origin to the mass: stroke s = d."""
    mech = build_mechanism(
        [rigid_link("ground", {"mount": _translate(-L0)}), rigid_link("mass")],
        [Joint("slide", "prismatic", "ground", "body", "mass", "body", q0=[S0])])
    cyl = HydraulicCylinder("lift", ("ground", "mount"), ("mass", "body"), bore=BORE,
                            rod=ROD, stroke=STROKE, length_retracted=L0,
                            supply_pressure=PS, nominal_flow=QNOM, nominal_drop=DPNOM,
                            command=command, **{"bulk_modulus": BETA, "laminar_drop": DPL,
                                                "initial_pressures": (PA0, PB0), **kw})
    return System(mech, {"mass": BodyMass.rigid(MASS, [0, 0, 0], np.eye(3))},
                  gravity=[0, 0, -G], forces=(cyl,)), cyl


def _reference(command, t_end, te, viscous=0.0):
    """The lift in its own four states (module docstring)."""
    kv = QNOM / np.sqrt(DPNOM)

    def orifice(dp):
        return dp / (dp * dp + DPL * DPL) ** 0.25

    def rhs(t, y):
        s, v, pa, pb = y
        u = float(np.clip(command.value(t), -1.0, 1.0))
        qa = kv * (max(u, 0) * orifice(PS - pa) - max(-u, 0) * orifice(pa))
        qb = kv * (max(-u, 0) * orifice(PS - pb) - max(u, 0) * orifice(pb))
        f = pa * AA - pb * AB - viscous * v
        return [v, f / MASS - G, BETA / (VA0 + AA * s) * (qa - AA * v),
                BETA / (VB0 + AB * (STROKE - s)) * (qb + AB * v)]

    sol = solve_ivp(rhs, (0.0, t_end), [S0, 0.0, PA0, PB0], method="Radau", t_eval=te,
                    rtol=1e-11, atol=[1e-13, 1e-12, 1e-4, 1e-4])
    return sol.y.T


def _run(system, te, step, **kw):
    return simulate(system, np.array([S0]), np.zeros(1), (0.0, te[-1]), te,
                    method="generalized_alpha", step=step, progress=False,
                    **{"rtol": 1e-5, "atol": 1e-8, **kw})


def test_the_valve_lifts_the_mass_as_the_hand_written_model_does():
    """A quintic command 0 -> 0.6 over 0.2 s; 0.4 s of lift. At 0.5 ms the stroke and both
    pressures match the reference, the run is ok (energy balance with the cylinder's work
    included), and the errors fall at second order with the step."""
    command = SmoothStep(0.0, 0.2, 0.0, 0.6)
    system, _ = _lift(command)
    te = np.linspace(0.0, 0.4, 41)
    ref = _reference(command, 0.4, te)
    errors = []
    for h in (1e-3, 5e-4, 2.5e-4):
        r = _run(system, te, h)
        assert r.success and r.state_names == ("lift.p_a", "lift.p_b")
        errors.append((np.abs(r.q[:, 0] - ref[:, 0]).max(),
                       np.abs(r.states - ref[:, 2:]).max()))
    assert ref[-1, 0] - S0 > 0.04  # it lifted
    assert r.verdict == "ok", r.report
    stroke, pressure = np.array(errors).T
    assert stroke[1] < 1e-6 and pressure[1] < 2e3, errors  # m; Pa of ~1e6
    for e in (stroke, pressure):
        assert np.all(np.log2(e[:-1] / e[1:]) > 1.7), errors
    # the cylinder's work lifted the mass: gravity's potential gained what it gave
    E = r.energies
    assert abs(-E["dissipated"][-1] - (E["gravity"][-1] - E["gravity"][0]
                                      + E["kinetic"][-1])) < 1e-6 * np.ptp(E["gravity"])


def test_with_the_valve_closed_the_oil_columns_ring_at_their_closed_form_frequency():
    """Held at rest by its pressures, nudged at 5 mm/s: the mass rings about its rest at
    sqrt(k / m), k = beta (A_a^2 / V_a + A_b^2 / V_b) (40 Hz here), and the pressures
    stay where they hold it on average."""
    system, cyl = _lift(0.0)
    k = cyl.oil_stiffness(S0)
    assert k == pytest.approx(BETA * (AA ** 2 / (VA0 + AA * S0)
                                      + AB ** 2 / (VB0 + AB * (STROKE - S0))))
    f_ref = np.sqrt(k / MASS) / (2 * np.pi)
    te = np.linspace(0.0, 0.25, 2501)
    r = simulate(system, np.array([S0]), np.array([5e-3]), (0.0, 0.25), te,
                 method="generalized_alpha", step=2.5e-5, progress=False, rho_inf=1.0,
                 rtol=1e-4, atol=1e-7)
    assert r.verdict == "ok", r.report
    v = r.qd[:, 0]
    up = np.nonzero((v[:-1] < 0) & (v[1:] >= 0))[0]
    t_up = te[up] - v[up] * (te[up + 1] - te[up]) / (v[up + 1] - v[up])
    f = (len(t_up) - 1) / (t_up[-1] - t_up[0])
    assert f == pytest.approx(f_ref, rel=1e-4), (f, f_ref)  # 3e-6 measured
    assert abs(r.q[:, 0].mean() - S0) < 1e-6
    assert r.state("lift.p_a").mean() == pytest.approx(PA0, rel=1e-3)


def test_the_compiled_forms_equal_the_numpy_methods_and_virtual_work():
    """On the flexible four-bar (the cylinder from ground to the coupler's flexible frame
    B, valve half open): the generalized force and the pressure rates of the compiled step
    equal the element's numpy methods, and the force is F dl/dq with dl/dq from finite
    differences of the markers' distance."""
    from pipeline.dynamics.forces.base import marker_pose
    from pipeline.kinematics import evaluate_tree
    from pipeline.solver import dae_kernels as K
    from pipeline.solver.dae_data import compile_dae, force_factors

    base = flexible_four_bar(n_modes=2).system
    cyl = HydraulicCylinder("c", ("ground", "O4"), ("coupler", "B"), bore=0.05, rod=0.03,
                            stroke=1.5, length_retracted=0.5, supply_pressure=150e5,
                            nominal_flow=1e-4, viscous_friction=300.0, coulomb_friction=80.0,
                            leakage=1e-12, command=0.5)
    s = System(base.mechanism, base.bodies, base.gravity, forces=(cyl,))
    rng = np.random.default_rng(7)
    q = assemble(s.mechanism, s.mechanism.q_initial).q + 0.01 * rng.standard_normal(s.mechanism.n)
    qd = rng.standard_normal(s.mechanism.n)
    z = np.array([60e5, 25e5])
    terms = equation_terms(s, q, qd, 0.0, z=z)
    rates = state_rates(s, q, qd, 0.0, z)
    data = compile_dae(s, np.arange(s.mechanism.n), np.zeros(0, dtype=int))
    args = (K.kin_tuple(data.kin), K.mass_tuple(data.masses), data.K, data.D, data.gravity4,
            data.w, data.forces)
    _, _, Qnc, _, _, _, zd = K.terms(q, qd, z, force_factors(data, [0.0])[0], *args)
    assert np.abs(Qnc - terms.Q_nonconservative).max() < 1e-9 * np.abs(Qnc).max()
    assert np.abs(zd - rates).max() < 1e-9 * np.abs(rates).max()

    def length(x):
        tree = evaluate_tree(s.mechanism, x, derivatives=False)
        pa, pb = (marker_pose(s, *m, tree, x)[:3, 3] for m in (cyl.marker_a, cyl.marker_b))
        return np.linalg.norm(pb - pa)

    dl = np.array([(length(q + 1e-7 * e) - length(q - 1e-7 * e)) / 2e-7
                   for e in np.eye(q.size)])
    from pipeline.dynamics.forces.hydraulics import piston_force

    F = piston_force(cyl.parameters(), z[0], z[1], length(q) - cyl.length_retracted,
                     float(dl @ qd))
    assert np.abs(terms.Q_forces - F * dl).max() < 1e-6 * np.abs(F * dl).max()


def test_analyses_that_do_not_carry_states_say_so():
    from pipeline.dynamics import static_equilibrium

    system, _ = _lift(0.0)
    with pytest.raises(ConfigError, match="only method='generalized_alpha'"):
        simulate(system, np.array([S0]), np.zeros(1), (0.0, 0.01), method="Radau",
                 progress=False)
    with pytest.raises(ConfigError, match="force element 'lift'.*states of its own"):
        static_equilibrium(system, np.array([S0]))


@pytest.mark.parametrize("field, value, match", [
    ("rod", 0.09, "rod: expected a diameter below the bore"),
    ("bore", -0.1, "bore: expected a number > 0"),
    ("initial_pressures", (1.0,), "initial_pressures: expected"),
    ("dead_volume_a", 0.0, "dead_volume_a: expected a volume > 0"),
    ("spool_overlap", 1.0, r"spool_overlap: expected a fraction .* in \(-1, 1\)"),
    ("spool_time_constant", -0.01, "spool_time_constant: expected a number > 0"),
])
def test_a_bad_cylinder_is_refused_naming_its_field(field, value, match):
    kw = {"bore": BORE, "rod": ROD, "stroke": STROKE, "length_retracted": L0,
          "supply_pressure": PS, "nominal_flow": QNOM}
    kw[field] = value
    with pytest.raises(ConfigError, match=match):
        HydraulicCylinder("c", ("ground", "a"), ("m", "b"), **kw)


def test_a_valve_driven_from_outside_brings_the_mass_to_its_goal():
    """A discrete proportional controller on the valve command (the Simulator's input by
    the cylinder's name) moves the mass 5 cm up: a valve-controlled cylinder integrates its
    flow, so it settles on the goal, with the valve closed and the pressures holding the
    mass (p_a A_a - p_b A_b = m g). A state saved and restored repeats its steps bit for
    bit, pressures included."""
    from pipeline.solver.simulator import Simulator

    system, _ = _lift(0.0, viscous_friction=1e4)  # seal friction: the oil spring settles
    # the command jumps at every call, and the pressures follow it: at rtol 1e-4 they are
    # 13x their tolerance off (against the same inputs replayed at h / 16), which the
    # calls' check now sees (81x) and calls suspect; 1 % of the pressures is asked here
    sim = Simulator(system, np.array([S0]), step=5e-4, inputs={"lift": 0.0}, rtol=1e-2,
                    atol=1e-7)
    goal = S0 + 0.05
    while sim.t < 1.0 - 1e-9:
        if abs(sim.t - 0.5) < 1e-9:
            saved = sim.state
            sim.step(0.005, {"lift": float(np.clip(40.0 * (goal - sim.q[0]), -1, 1))})
            again = sim.q.copy(), sim.state.z.copy()
            sim.set_state(saved)
        sim.step(0.005, {"lift": float(np.clip(40.0 * (goal - sim.q[0]), -1, 1))})
        if abs(sim.t - 0.505) < 1e-9:
            assert np.array_equal(sim.q, again[0]) and np.array_equal(sim.state.z, again[1])
    r = sim.result()
    assert r.verdict == "ok", r.report
    assert abs(r.q[-1, 0] - goal) < 1e-4 and abs(r.qd[-1, 0]) < 1e-3
    pa, pb = r.states[-1]
    assert pa * AA - pb * AB == pytest.approx(MASS * G, rel=1e-3)


def test_what_the_model_leaves_out_is_reported():
    """Fully open for 1.2 s the mass runs past the stroke's end (no end stops given); a 20 t
    load lowered with the valve fully open runs away from the rod side's supply, whose
    pressure falls far below -1 bar (cavitation, not modelled). Each is named, and the
    run is not ok."""
    from dataclasses import replace

    system, _ = _lift(1.0)
    r = _run(system, np.linspace(0.0, 1.2, 61), 1e-3)
    assert r.verdict == "suspect"
    text = " ".join(r.warnings)
    assert "hydraulic cylinder 'lift': its stroke reached 0.52" in text, r.warnings
    assert "outside [0, 0.5] m" in text and "pressure fell" not in text
    system, _ = _lift(-1.0)
    system = replace(system, bodies={"mass": BodyMass.rigid(2e4, [0, 0, 0], np.eye(3))})
    r = _run(system, np.linspace(0.0, 0.3, 31), 1e-3)
    assert r.verdict == "suspect"
    (w,) = [w for w in r.warnings if "cylinder" in w]
    assert w.startswith("hydraulic cylinder 'lift': the b-side pressure fell to -9"), w


def test_the_error_estimates_cover_the_pressures():
    """A fixed step's estimate (the run again at twice the step) includes the states: at
    2 ms the pressures are what is off (385 Pa against a 36 Pa tolerance) and the estimate
    names them and bounds it; adaptive steps control them too (at rtol 1e-6, 57 Pa of
    3.6 MPa)."""
    command = SmoothStep(0.0, 0.2, 0.0, 0.6)
    system, _ = _lift(command)
    te = np.linspace(0.0, 0.4, 41)
    ref = _reference(command, 0.4, te)
    r = _run(system, te, 2e-3)
    tol = 1e-8 * 1e5 + 1e-5 * np.abs(r.states).max(axis=0)
    true = (np.abs(r.states - ref[:, 2:]) / tol).max()
    est = r.step_stats["error_ratio"]
    assert r.step_stats["error_coordinate"].startswith("lift.p_")
    assert true > 1.0 and true <= est <= 5 * true and r.verdict == "suspect", (true, est)
    a = simulate(system, np.array([S0]), np.zeros(1), (0.0, 0.4), te,
                 method="generalized_alpha", progress=False, rtol=1e-6, atol=1e-8)
    assert a.verdict == "ok" and np.abs(a.states - ref[:, 2:]).max() < 2e-5 * PA0 * 5


def test_the_simulator_s_error_estimate_covers_the_pressures_too():
    """The same lift stepped from outside in calls of 10 ms at 2 ms steps: each call's check
    run compares the pressures as well as the coordinates, so the result names a pressure
    and is suspect, as simulate's estimate is (it compared the coordinates only: ok).
    The pressures are 10.5x their tolerance off; the calls' summed estimate says 70, the
    replay 28."""
    from pipeline.solver.simulator import Simulator

    command = SmoothStep(0.0, 0.2, 0.0, 0.6)
    system, _ = _lift(command)
    te = np.linspace(0.0, 0.4, 41)
    ref = _reference(command, 0.4, te)
    sim = Simulator(system, np.array([S0]), step=2e-3, rtol=1e-5, atol=1e-8)
    while sim.t < 0.4 - 1e-9:
        sim.step(0.01)
        assert sim.error_ratio >= 0.0
    r = sim.result()
    tol = 1e-8 * 1e5 + 1e-5 * np.abs(r.states).max(axis=0)
    true = (np.abs(r.states - ref[:, 2:]) / tol).max()
    assert r.step_stats["error_coordinate"].startswith("lift.p_"), r.step_stats
    assert true > 1.0 and true <= r.step_stats["error_ratio"] <= 10 * true, \
        (true, r.step_stats["error_ratio"])
    assert r.verdict == "suspect" and sim.error_ratio == r.step_stats["error_ratio"]
    replayed = sim.result(replay=True)
    assert replayed.step_stats["error_coordinate"].startswith("lift.p_")
    assert true <= replayed.step_stats["error_ratio"] <= 10 * true


def test_the_steady_extension_against_a_load_is_the_valves_closed_form():
    """Valve held at u = 0.5: the mass rises at the speed where the metering edges' flows
    and the force balance meet, A_a v = K u sqrt(p_s - p_a), A_b v = K u sqrt(p_b - p_t),
    p_a A_a - p_b A_b = m g + c v, i.e. v^2 (A_a^3 + A_b^3) / (K u)^2 + c v = p_s A_a - m g
    (sharp-edged orifices: laminar drop 10 Pa; seal friction damps the start's ringing)."""
    u, c = 0.5, 2e4
    system, _ = _lift(u, viscous_friction=c, laminar_drop=10.0)
    te = np.linspace(0.0, 0.3, 31)
    r = simulate(system, np.array([S0]), np.zeros(1), (0.0, 0.3), te,
                 method="generalized_alpha", progress=False, rtol=1e-7, atol=1e-9)
    ku = QNOM / np.sqrt(DPNOM) * u
    a2 = (AA ** 3 + AB ** 3) / ku ** 2
    v = (-c + np.sqrt(c * c + 4 * a2 * (PS * AA - MASS * G))) / (2 * a2)
    assert r.verdict == "ok", r.report
    assert r.qd[-1, 0] == pytest.approx(v, rel=1e-5), (r.qd[-1, 0], v)
    pa, pb = r.states[-1]
    assert pa == pytest.approx(PS - (AA * v / ku) ** 2, rel=1e-5)
    assert pb == pytest.approx((AB * v / ku) ** 2, rel=1e-4)


def test_a_hold_pressure_starts_the_machine_at_rest():
    """``initial_pressures: [hold, p_b]``: the piston side's pressure is found so that the
    load rests on the closed valve, (m g + p_b A_b) / A_a by hand; the mass then stays put.
    On the four-bar (a closed loop) a cylinder from ground to the coupler holds the crank
    where it starts under gravity: it moves 1e-3 of what it does without the cylinder.
    (Rigid links: flexible ones start undeformed, as given, and their ringing moves the
    joints.) A pose the held pressure cannot hold (a free arm swinging on the mass) is
    named before the run."""
    system, _ = _lift(0.0, initial_pressures=("hold", PB0))
    r = _run(system, np.linspace(0.0, 0.2, 21), 1e-3)
    assert r.states[0, 0] == pytest.approx(PA0, rel=1e-12)
    assert r.verdict == "ok" and np.abs(r.q[:, 0] - S0).max() < 1e-9

    base = flexible_four_bar(n_modes=0).system
    q0 = assemble(base.mechanism, base.mechanism.q_initial).q
    cyl = HydraulicCylinder("c", ("ground", "body"), ("coupler", "B"), bore=0.05, rod=0.03,
                            stroke=1.5, length_retracted=2.0, supply_pressure=150e5,
                            nominal_flow=1e-4, initial_pressures=("hold", 5e5))
    runs = [simulate(System(base.mechanism, base.bodies, base.gravity, forces=f), q0,
                     np.zeros_like(q0), (0.0, 0.3), np.linspace(0.0, 0.3, 31),
                     method="generalized_alpha", step=1e-3, progress=False, rtol=1e-4,
                     atol=1e-6) for f in ((cyl,), ())]
    moved = [np.abs(r.q[:, 0] - q0[0]).max() for r in runs]
    assert runs[0].verdict == "ok" and moved[1] > 0.01 and moved[0] < 1e-3 * moved[1], moved

    mech = build_mechanism(
        [rigid_link("ground", {"mount": _translate(-L0)}), rigid_link("mass"),
         rigid_link("arm")],
        [Joint("slide", "prismatic", "ground", "body", "mass", "body", q0=[S0]),
         Joint("pin", "revolute", "mass", "body", "arm", "body")])
    cyl = HydraulicCylinder("lift", ("ground", "mount"), ("mass", "body"), bore=BORE,
                            rod=ROD, stroke=STROKE, length_retracted=L0,
                            supply_pressure=PS, nominal_flow=QNOM,
                            initial_pressures=("hold", PB0))
    s = System(mech, {"mass": BodyMass.rigid(MASS, [0, 0, 0], np.eye(3)),
                      "arm": BodyMass.rigid(10.0, [0.5, 0, 0], np.eye(3))},
               gravity=[0, -G, 0], forces=(cyl,))
    with pytest.raises(ConfigError, match=r"cannot hold the machine at rest.*\['pin\.theta'\]"):
        simulate(s, np.array([S0, 0.0]), np.zeros(2), (0.0, 0.01), method="generalized_alpha",
                 step=1e-3, progress=False)


def test_joint_reactions_carry_the_cylinders_loads():
    """The four-bar pushed by a cylinder through its opening valve: the joint reactions,
    from Newton-Euler of every link with the cylinder's loads at the run's pressures,
    balance each link (residual 1e-9 of the loads), so the checks that read them (the
    axial-load check) are made on hydraulic machines too."""
    from pipeline.dynamics.kinetostatics import joint_reactions

    base = flexible_four_bar(n_modes=0).system
    q0 = assemble(base.mechanism, base.mechanism.q_initial).q
    cyl = HydraulicCylinder("c", ("ground", "body"), ("coupler", "B"), bore=0.05, rod=0.03,
                            stroke=1.5, length_retracted=2.0, supply_pressure=150e5,
                            nominal_flow=3e-4, initial_pressures=("hold", 5e5),
                            command=SmoothStep(0.0, 0.1, 0.0, 0.3))
    s = System(base.mechanism, base.bodies, base.gravity, forces=(cyl,))
    r = simulate(s, q0, np.zeros_like(q0), (0.0, 0.2), np.linspace(0.0, 0.2, 11),
                 method="generalized_alpha", step=5e-4, progress=False, rtol=1e-4, atol=1e-6)
    assert r.verdict == "ok" and np.ptp(r.q[:, 0]) > 0.01, r.report
    for k in (3, 7, 10):
        rx = joint_reactions(s, r.q[k], r.qd[k], r.qdd[k], float(r.t[k]), {}, r.states[k])
        scale = np.abs(rx.force).max()
        assert rx.residual < 1e-9 * scale and scale > 10.0, (rx.residual, scale)


def test_a_pump_of_given_flow_builds_its_pressure_then_the_relief_valve_holds_it():
    """``pump_flow`` Q into a supply line of volume V_s, valve closed: its pressure rises
    at beta Q / V_s (a straight line, by hand) until the relief valve opens, then settles
    where the relief passes the whole flow: p_relief + 1e4 ln(exp(Q / (k_r 1e4)) - 1), the
    smoothed valve's law inverted by hand. The load rests on its held pressure meanwhile."""
    q, vs, pr, kr = 2e-4, 2e-2, 150e5, 1e-9  # 100 bar/s; the relief's time constant 20 ms
    system, _ = _lift(0.0, pump_flow=q, supply_volume=vs, relief_pressure=pr,
                      relief_gain=kr, initial_pressures=("hold", PB0))
    te = np.linspace(0.0, 3.0, 301)
    r = simulate(system, np.array([S0]), np.zeros(1), (0.0, 3.0), te,
                 method="generalized_alpha", progress=False, rtol=1e-8, atol=1e-10)
    assert r.verdict == "ok" and r.state_names == ("lift.p_a", "lift.p_b", "lift.p_s")
    ps = r.state("lift.p_s")
    rising = te < 0.5 * pr / (BETA * q / vs)  # well below the relief's opening
    assert rising.sum() > 50
    assert np.abs(ps[rising] - BETA * q / vs * te[rising]).max() < 1e-6 * pr
    settled = pr + 1e4 * np.log(np.expm1(q / (kr * 1e4)))
    assert ps[-1] == pytest.approx(settled, rel=1e-6), (ps[-1], settled)
    assert np.abs(r.q[:, 0] - S0).max() < 1e-9


def test_the_linearised_frequency_includes_the_oil_columns():
    """vibration_modes about the rest the hold pressures keep (issue 27, item 4): the
    oil-column frequency sqrt(beta (A_a^2 / V_a + A_b^2 / V_b) / m) in closed form, and
    its pressures' share of the mode. The two neutral directions (the oil trapped on each
    side: a family of equilibria) are not modes."""
    from pipeline.dynamics.linearize import vibration_modes

    system, _ = _lift(0.0, initial_pressures=("hold", PB0))
    modes = vibration_modes(system, np.array([S0]))
    va, vb = VA0 + AA * S0, VB0 + AB * (STROKE - S0)
    omega = np.sqrt(BETA * (AA ** 2 / va + AB ** 2 / vb) / MASS)
    assert modes.model.state_names == ("lift.p_a", "lift.p_b")
    np.testing.assert_allclose(modes.model.z, [PA0, PB0], rtol=1e-12)
    ring = np.flatnonzero(modes.frequencies_hz > 0)
    assert modes.omega.size == 1 and ring.size == 1
    assert abs(modes.omega[ring[0]] / omega - 1.0) < 1e-6, (modes.omega, omega)
    assert abs(modes.damping_ratios[ring[0]]) < 1e-9
    # a stroke dx compresses side a by beta A_a dx / V_a and relieves side b
    dz = modes.shapes_z[:, ring[0]] / modes.shapes[0, ring[0]]
    np.testing.assert_allclose(dz.real, [-BETA * AA / va, BETA * AB / vb], rtol=1e-6)


def test_the_linearised_model_with_friction_and_leakage_is_the_hand_built_one():
    """Viscous seal friction c and leakage c_l across the piston: about the rest where both
    chambers hold p = m g / (A_a - A_b), the eigenvalues of the hand-linearised four-state
    model [s, v, p_a, p_b] (damped oil column, and the slow leak-down of the load)."""
    from pipeline.dynamics.linearize import vibration_modes

    c, cl = 2.0e3, 2.0e-11
    p = MASS * G / (AA - AB)
    system, _ = _lift(0.0, viscous_friction=c, leakage=cl, initial_pressures=(p, p))
    modes = vibration_modes(system, np.array([S0]))
    va, vb = VA0 + AA * S0, VB0 + AB * (STROKE - S0)
    A = np.array([[0.0, 1.0, 0.0, 0.0],
                  [0.0, -c / MASS, AA / MASS, -AB / MASS],
                  [0.0, -BETA * AA / va, -BETA * cl / va, BETA * cl / va],
                  [0.0, BETA * AB / vb, BETA * cl / vb, -BETA * cl / vb]])
    lam = np.linalg.eigvals(A)
    lam = lam[np.abs(lam) > 1e-9 * np.abs(lam).max()]  # the total oil's neutral direction
    ref = np.sort(np.abs(lam[lam.imag >= -1e-9 * np.abs(lam).max()]))
    assert ref.size == 2  # the damped oil column and the load's leak-down
    np.testing.assert_allclose(np.sort(modes.omega), ref, rtol=1e-6)
    ring = np.argmax(modes.frequencies_hz)
    pair = lam[np.argmax(lam.imag)]
    assert abs(modes.damping_ratios[ring] + pair.real / abs(pair) ) < 1e-6
    assert modes.damping_ratios[ring] > 0.005  # the seal friction damps it


BOOM = {"L": 3.0, "a": 1.0, "h": 1.0, "M": 2000.0, "E": 2.1e11, "Iz": 1.2e-4, "bore": 0.1,
        "rod": 0.05, "stroke": 0.5, "L0": 0.8, "dead": 1e-4}


def _boom(folder, rho=7.85, modes="{count: 4, craig_bampton: true}"):
    """A beam boom (length L, pinned at its root; light by default) with a tip mass M on
    a vertical cylinder at a from the root, valve closed, the piston side holding it."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from link_samples import boom_spec

    from pipeline.dynamics import body_from_reduced, link_from_reduced
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    b = BOOM
    text = boom_spec(b["L"], b["a"], A=0.01, Iy=1e-3, Iz=b["Iz"], J=2e-4, E=b["E"], rho=rho,
                     modes=modes, element_size=0.1)
    text += f"point_masses:\n  - {{name: load, position: [{b['L']!r}, 0, 0], mass: {b['M']!r}}}\n"
    (folder / "boom.yaml").write_text(text)
    red = reduce_spec(load_link_spec(folder / "boom.yaml"), folder, folder / "links")[0]
    mount = np.eye(4)
    mount[:3, 3] = [b["a"], -b["h"], 0.0]
    mech = build_mechanism([rigid_link("ground", {"mount": mount}),
                            link_from_reduced(red, name="boom")],
                           [Joint("pivot", "revolute", "ground", "body", "boom", "root")])
    cyl = HydraulicCylinder("lift", ("ground", "mount"), ("boom", "pin"), bore=b["bore"],
                            rod=b["rod"], stroke=b["stroke"], length_retracted=b["L0"],
                            supply_pressure=200e5, nominal_flow=1e-3,
                            dead_volume_a=b["dead"], dead_volume_b=b["dead"],
                            initial_pressures=("hold", 10e5))
    return System(mech, {"boom": body_from_reduced(red)}, gravity=[0, -G, 0], forces=(cyl,))


def test_a_flexible_boom_on_its_cylinder_rings_at_the_two_spring_frequency(tmp_path):
    """Hand-built reference: the tip sees two springs in series, the oil columns' k_oil
    reflected by the lever, k_oil a^2 / L^2, and the overhang's bending (span a, overhang
    c = L - a: tip deflection P c^2 L / (3 E I)), so omega^2 = k / M with 1/k = L^2 /
    (a^2 k_oil) + c^2 L / (3 E I). The linearised machine (oil pressures as states) gives
    its first frequency; the boom's mass is 1e-4 of M."""
    from pipeline.dynamics import static_equilibrium
    from pipeline.dynamics.linearize import vibration_modes

    system = _boom(tmp_path)
    q0 = np.zeros(system.mechanism.n)
    z = system.initial_states(q0)
    st = static_equilibrium(system, q0, z=z)
    assert st.success, st.message
    modes = vibration_modes(system, st.q, z_eq=z)
    b = BOOM
    L, a, E, Iz, dead, stroke = b["L"], b["a"], b["E"], b["Iz"], b["dead"], b["stroke"]
    s = b["h"] - b["L0"]
    aa, ab = np.pi / 4 * b["bore"] ** 2, np.pi / 4 * (b["bore"] ** 2 - b["rod"] ** 2)
    k_oil = 1.0e9 * (aa ** 2 / (dead + aa * s) + ab ** 2 / (dead + ab * (stroke - s)))
    k = 1.0 / (L ** 2 / (a ** 2 * k_oil) + (L - a) ** 2 * L / (3 * E * Iz))
    omega = np.sqrt(k / b["M"])
    first = modes.omega[modes.frequencies_hz > 0].min()
    assert abs(first / omega - 1.0) < 5e-4, (first, omega, modes.omega[:6])  # 1.2e-4
    # each spring matters: the boom alone, or the oil alone, is far off
    assert first < 0.8 * np.sqrt(k_oil * a ** 2 / L ** 2 / b["M"])
    assert first < 0.8 * np.sqrt(3 * E * Iz / ((L - a) ** 2 * L) / b["M"])


def test_a_static_start_under_held_pressures_leaves_the_flexible_boom_at_rest(tmp_path):
    """The hold pressure is found with the boom undeformed; the statics with that pressure
    held deflect the boom, and a run from there stays at rest (from the undeformed pose the
    boom rings by its whole static deflection)."""
    from pipeline.dynamics import static_equilibrium

    system = _boom(tmp_path, rho=7850.0, modes="{count: 3}")
    q0 = np.zeros(system.mechanism.n)
    st = static_equilibrium(system, q0, z=system.initial_states(q0))
    assert st.success, st.message
    modal = system.mechanism.modal_coordinates
    sag = np.abs(st.q[modal]).max()
    assert sag > 1e-6
    te = np.linspace(0.0, 0.08, 9)  # half the ring's period
    for start, bound in ((st.q, 1e-6 * sag), (q0, 0.5 * sag)):
        r = simulate(system, start, np.zeros_like(start), (0.0, 0.08), te,
                     method="generalized_alpha", step=2e-3, rtol=1e-4, atol=1e-9,
                     progress=False)
        assert r.success, r.message
        moved = np.abs(r.q[:, modal] - st.q[modal]).max()
        assert (moved < bound) == (start is st.q), (moved, sag)


def test_a_first_order_spool_follows_a_ramp_command_as_its_closed_form():
    """x' = (u - x) / tau under u = r t from rest at 0: x = r (t - tau (1 - exp(-t / tau)));
    second order in the step."""
    from pipeline.kinematics.drivers import Ramp

    tau, r = 0.02, 2.0
    system, _ = _lift(Ramp(0.0, r), spool_time_constant=tau)
    assert system.state_names[-1] == "lift.x_v"
    te = np.linspace(0.0, 0.2, 21)
    exact = r * (te - tau * (1.0 - np.exp(-te / tau)))
    errors = []
    for h in (1e-3, 5e-4):
        res = _run(system, te, h)
        assert res.success, res.message
        errors.append(np.abs(res.state("lift.x_v") - exact).max())
    assert errors[1] < 1e-6 and errors[0] / errors[1] > 3.8, errors  # 3.1e-6, 7.7e-7


def _reference_spool(command, t_end, te, tau=None, f_v=None, zeta_v=0.7, overlap=0.0):
    """The lift of _reference with its spool's own states: a first-order lag tau or a
    second-order one (f_v, zeta_v), and edges of overlap o opening as clip((x - o) /
    (1 - o), 0, 1)."""
    kv = QNOM / np.sqrt(DPNOM)
    w = 2 * np.pi * (f_v or 0.0)

    def orifice(dp):
        return dp / (dp * dp + DPL * DPL) ** 0.25

    def edge(x):
        return min(max((min(max(x, -1.0), 1.0) - overlap) / (1.0 - overlap), 0.0), 1.0)

    def rhs(t, y):
        s, v, pa, pb, x, xd = y
        u = float(np.clip(command.value(t), -1.0, 1.0))
        ap, an = edge(x), edge(-x)
        qa = kv * (ap * orifice(PS - pa) - an * orifice(pa))
        qb = kv * (an * orifice(PS - pb) - ap * orifice(pb))
        f = pa * AA - pb * AB
        xdd = w * w * (u - x) - 2 * zeta_v * w * xd if f_v else 0.0
        return [v, f / MASS - G, BETA / (VA0 + AA * s) * (qa - AA * v),
                BETA / (VB0 + AB * (STROKE - s)) * (qb + AB * v),
                xd if f_v else (u - x) / tau, xdd]

    sol = solve_ivp(rhs, (0.0, t_end), [S0, 0.0, PA0, PB0, 0.0, 0.0], method="Radau",
                    t_eval=te, rtol=1e-11, atol=[1e-13, 1e-12, 1e-4, 1e-4, 1e-12, 1e-10])
    return sol.y.T


@pytest.mark.parametrize("spool", [{"spool_time_constant": 0.02},
                                   {"spool_frequency": 20.0, "spool_damping": 0.6}])
def test_the_lift_through_a_lapped_spool_with_dynamics_is_the_hand_written_model(spool):
    """The quintic command of the first test through a spool with a 10 % overlap (a dead
    band) and first- or second-order dynamics, against the hand-written six-state model."""
    command = SmoothStep(0.0, 0.2, 0.0, 0.6)
    system, _ = _lift(command, spool_overlap=0.1, **spool)
    te = np.linspace(0.0, 0.4, 41)
    ref = _reference_spool(command, 0.4, te, tau=spool.get("spool_time_constant"),
                           f_v=spool.get("spool_frequency"),
                           zeta_v=spool.get("spool_damping", 0.7), overlap=0.1)
    # the edges' kinks as the spool passes the overlap cost the step its order there: the
    # run's own estimate says so at rtol 1e-5 (15x), so the tolerance asked is looser
    r = _run(system, te, 2.5e-4, rtol=1e-3)
    assert r.success and r.verdict == "ok", r.report
    assert ref[-1, 0] - S0 > 0.02  # it lifted
    assert np.abs(r.q[:, 0] - ref[:, 0]).max() < 1e-6
    assert np.abs(r.states[:, :2] - ref[:, 2:4]).max() < 2e3  # Pa of ~1e6
    assert np.abs(r.state("lift.x_v") - ref[:, 4]).max() < 1e-5


def test_a_spool_has_one_kind_of_dynamics():
    with pytest.raises(ConfigError, match="spool_frequency: give the spool a first-order"):
        _lift(0.0, spool_time_constant=0.01, spool_frequency=30.0)


def test_a_command_within_the_dead_band_moves_nothing():
    """Overlap 0.1: a command of 0.08 opens no edge, and the held mass stays at rest (at
    zero lap it rises)."""
    te = np.linspace(0.0, 0.2, 11)
    for overlap, still in ((0.1, True), (0.0, False)):
        system, _ = _lift(0.08, spool_overlap=overlap, initial_pressures=("hold", PB0))
        r = _run(system, te, 1e-3)
        assert r.success
        assert (np.abs(r.q[:, 0] - S0).max() < 1e-9) == still


def test_an_underlapped_spool_at_centre_holds_each_chamber_at_half_the_supply():
    """Underlap 0.1, command 0, the piston held by a driver: each chamber is fed from P and
    drained to T by edges open alike, so it settles at (p_s + p_t) / 2 (equal orifices)."""
    from pipeline.kinematics.driver_base import Constant

    system, _ = _lift(0.0, spool_overlap=-0.1)
    system = replace(system, drivers={"slide.d": Constant(S0)})
    te = np.linspace(0.0, 1.5, 16)
    r = _run(system, te, 5e-4, rtol=1e-4)
    assert r.success and r.verdict == "ok", r.report
    np.testing.assert_allclose(r.states[-1, :2], [PS / 2, PS / 2], rtol=1e-6)


def test_the_mass_rests_on_the_retracted_end_stop_at_its_closed_form_depth():
    """Both chambers at tank pressure, no oil force: the mass sits on the retracted end
    stop, m g / k_e deep (statics with the pressures held)."""
    from pipeline.dynamics import static_equilibrium

    k = 5.0e7
    system, _ = _lift(0.0, end_stiffness=k, end_damping=0.0, initial_pressures=(0.0, 0.0))
    st = static_equilibrium(system, np.array([-1e-4]), z=np.zeros(2))  # in contact
    assert st.success, st.message
    assert abs(st.q[0] - (-MASS * G / k)) < 1e-9 * MASS * G / k + 1e-15


@pytest.mark.parametrize("damping", [0.0, 2.0])
def test_a_mass_dropped_on_the_end_stop_sinks_as_deep_as_its_energy_allows(damping):
    """The mass falls 5 cm onto the retracted end stop (oil with a bulk modulus of 1 Pa:
    no oil force). Without damping the deepest point meets m g (h + d) = k_e d^2 / 2 and it
    rebounds to its height (the stop's work returned); with Hunt-Crossley damping it sinks
    less and rebounds lower, the energy balance holding with the stop's work."""
    k, h = 2.0e6, 0.05
    system, _ = _lift(0.0, end_stiffness=k, end_damping=damping, bulk_modulus=1.0,
                      initial_pressures=(0.0, 0.0))
    te = np.linspace(0.0, 0.4, 401)
    r = simulate(system, np.array([h]), np.zeros(1), (0.0, 0.4), te,
                 method="generalized_alpha", step=2e-5, rtol=1e-4, atol=1e-9,
                 progress=False)
    assert r.success and r.verdict == "ok", r.report
    w = MASS * G
    deepest = (w + np.sqrt(w * w + 2 * k * w * h)) / k
    bounce = r.q[te > 0.15, 0].max()  # after the first contact
    if damping == 0.0:
        assert abs(-r.q[:, 0].min() / deepest - 1.0) < 5e-4, (r.q[:, 0].min(), deepest)
        assert abs(bounce / h - 1.0) < 1e-3, bounce  # 9e-5 (outputs 1 ms apart), 2e-5
    else:
        assert -r.q[:, 0].min() < 0.97 * deepest and bounce < 0.8 * h, (r.q[:, 0].min(), bounce)
