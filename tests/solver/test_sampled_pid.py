"""A built-in digital controller beside the machine (pipeline.solver.cosim.SampledPID): a
PID sampled every T with its output held, on the hydraulic lift of
``test_hydraulic_cylinder.py`` (its valve command the controller's output).

References built here: the lift's four states written by hand and integrated by scipy's
Radau between the sampling instants, with the discrete law written out (the package's
equations and its master loop are not used); and the cylinder's continuous PID, which the
sampled one approaches at the period's first order."""

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
from pipeline.dynamics.forces.hydraulics import PID, anti_windup_time
from pipeline.kinematics.drivers import SmoothStep
from pipeline.solver import simulate
from pipeline.solver.cosim import SampledPID, cosimulate
from pipeline.solver.simulator import Simulator

VISCOUS = 1e4  # N s/m: seal friction, so that the oil spring's ringing settles
MOVE = SmoothStep(0.0, 0.3, S0, S0 + 0.05)


def _plant(u):
    kv = QNOM / np.sqrt(DPNOM)

    def orifice(dp):
        return dp / (dp * dp + DPL * DPL) ** 0.25

    def rhs(t, y):
        s, v, pa, pb = y
        qa = kv * (max(u, 0) * orifice(PS - pa) - max(-u, 0) * orifice(pa))
        qb = kv * (max(-u, 0) * orifice(PS - pb) - max(u, 0) * orifice(pb))
        return [v, (pa * AA - pb * AB - VISCOUS * v) / MASS - G,
                BETA / (VA0 + AA * s) * (qa - AA * v),
                BETA / (VB0 + AB * (STROKE - s)) * (qb + AB * v)]

    return rhs


def _reference(c: SampledPID, t_end: float) -> np.ndarray:
    """(K + 1, 4) the lift's states at the sampling instants under the discrete law."""
    T = c.period
    y, x, y_last, out = np.array([S0, 0.0, PA0, PB0]), 0.0, None, []
    tt = anti_windup_time(c.kp, c.ki, c.kd, c.tracking_time)
    lo, hi = c.output_limits or (-np.inf, np.inf)
    for k in range(round(t_end / T)):
        t = k * T
        out.append(y)
        e = c.reference.value(t) - y[0]
        d = 0.0 if y_last is None else (y[0] - y_last) / T
        v = c.feedforward * c.reference.rate(t) + c.kp * e + x - c.kd * d
        u = min(max(v, lo), hi)
        x += T * (c.ki * e + (u - v) / tt) if c.ki else 0.0
        y_last = y[0]
        y = solve_ivp(_plant(u), (t, t + T), y, method="Radau", rtol=1e-11,
                      atol=[1e-13, 1e-12, 1e-4, 1e-4]).y[:, -1]
    out.append(y)
    return np.array(out)


def _sim(h):
    system, _ = _lift(0.0, viscous_friction=VISCOUS)
    return Simulator(system, np.array([S0]), step=h, inputs={"lift": 0.0}, rtol=1e-5,
                     atol=1e-8)


@pytest.mark.parametrize("case", ["tracking", "clipped"])
def test_the_sampled_pid_is_the_hand_written_discrete_loop(case):
    """Tracking: a 5 cm move with a derivative term and feed-forward. Clipped: the valve
    held at its 0.4 limit and the integral pulled back. The stroke and pressures at the
    sampling instants match the hand-written loop at second order in the machine's step."""
    c = SampledPID("q:slide.d", "lift", MOVE, kp=20.0, ki=40.0, kd=0.3, period=0.01,
                   feedforward=1.0, output_limits=(-1.0, 1.0))
    if case == "clipped":
        c = replace(c, reference=SmoothStep(0.0, 0.02, S0, S0 + 0.2), kd=0.0,
                    feedforward=0.0, output_limits=(-0.4, 0.4))
    ref = _reference(c, 0.6)
    errors = []
    for h in (1e-3, 5e-4, 2.5e-4):
        r = cosimulate(_sim(h), [c], 0.6, c.period)
        assert r.success and r.t.size == ref.shape[0]
        errors.append((np.abs(r.q[:, 0] - ref[:, 0]).max(),
                        np.abs(r.states[:, :2] - ref[:, 2:]).max()))
    stroke, pressure = np.array(errors).T
    assert stroke[-1] < 5e-7 and pressure[-1] < 2e3, errors  # m; Pa of ~5 MPa
    assert np.all(np.log2(stroke[:-1] / stroke[1:]) > 1.6), errors
    if case == "clipped":  # the valve sat at its limit for a while: the move is slower
        assert ref[10, 0] - S0 < 0.9 * (0.2 * 0.1)


def test_the_sampled_pid_approaches_the_continuous_one_at_first_order_in_its_period():
    """The cylinder's own (continuous) PID with the same gains against the sampled one at
    periods 8, 4, 2 ms: the difference halves with the period (a zero-order hold lags half
    a period)."""
    pid = PID(MOVE, kp=20.0, ki=40.0)
    te = np.linspace(0.0, 0.4, 51)
    cont = simulate(_lift(pid, viscous_friction=VISCOUS)[0], np.array([S0]), np.zeros(1),
                    (0.0, 0.4), te, method="generalized_alpha", step=2.5e-4, rtol=1e-5,
                    atol=1e-8, progress=False)
    gaps = []
    for T in (8e-3, 4e-3, 2e-3):
        r = cosimulate(_sim(2.5e-4), [SampledPID("q:slide.d", "lift", MOVE, kp=20.0,
                                                 ki=40.0, period=T)], 0.4, T)
        at = np.interp(te, r.t, r.q[:, 0])
        gaps.append(np.abs(at - cont.q[:, 0]).max())
    ratios = np.array(gaps[:-1]) / np.array(gaps[1:])
    assert np.all((ratios > 1.6) & (ratios < 2.6)), gaps
    assert gaps[-1] < 2e-4  # m, of a 5 cm move


@pytest.mark.parametrize("kw, match", [
    ({"kp": -1.0}, "kp: expected a gain >= 0"),
    ({"period": 0.0}, "period: expected seconds > 0"),
    ({"output_limits": (1.0, -1.0)}, "output_limits"),
    ({"tracking_time": float("nan")}, "tracking_time"),
])
def test_a_bad_sampled_pid_is_refused_naming_its_field(kw, match):
    with pytest.raises(ConfigError, match=f"sampled PID: {match}"):
        SampledPID("q:slide.d", "lift", S0, **{"kp": 1.0, **kw})


@pytest.mark.parametrize("kw, match", [
    ({"period": 0.015}, r"period 0.015 s is not a whole multiple of the macro step 0.01 s"),
    ({"output": "lfit"}, r"output drives 'lfit', which is not an input"),
    ({"measured": "q:slide.x"}, r"signal 'q:slide.x'"),
])
def test_bad_connections_are_named_before_anything_runs(kw, match):
    c = SampledPID(**{"measured": "q:slide.d", "output": "lift", "reference": S0, "kp": 1.0,
                      "period": 0.01, **kw})
    sim = _sim(1e-3)
    with pytest.raises(ConfigError, match=match):
        cosimulate(sim, [c], 0.1, 0.01)
    assert sim.t == 0.0


def test_one_input_driven_twice_is_refused():
    c = SampledPID("q:slide.d", "lift", S0, kp=1.0)
    with pytest.raises(ConfigError, match=r"\['lift'\] driven by more than one block output"):
        cosimulate(_sim(1e-3), [c, c], 0.1, 0.01)


def _workflow(tmp_path, controller: str) -> Path:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflows"))
    from test_hydraulic_workflow import LIFT

    text = LIFT.replace(
        "    command: {type: smooth_step, t0: 0.0, t1: 0.2, v0: 0.0, v1: 0.6}\n",
        "    viscous_friction: 1.0e4\n").replace(
        "    atol: 1.0e-8\n", "    atol: 1.0e-8\n    controllers:\n" + controller)
    p = tmp_path / "lift.yaml"
    p.write_text(text.replace("rtol: 1.0e-4", "rtol: 1.0e-5"))
    return p


CONTROLLER = ("      - measured: q:slide.d\n        output: lift\n"
              f"        reference: {{type: smooth_step, t0: 0.0, t1: 0.3, v0: {S0}, "
              f"v1: {S0 + 0.05}}}\n        kp: 20.0\n        ki: 40.0\n        period: 0.01\n")


def test_a_workflow_runs_its_controller_as_the_python_api_does(tmp_path):
    from pipeline.workflow import run_workflow

    res = run_workflow(_workflow(tmp_path, CONTROLLER), out_root=tmp_path / "out")
    r = res.result("raise", "")
    ref = cosimulate(_sim(5e-4), [SampledPID("q:slide.d", "lift", MOVE, kp=20.0, ki=40.0,
                                             period=0.01)], 0.4, 0.01)
    assert r.success and r.t.size == 41  # the sampling instants
    assert np.abs(r.q - ref.q).max() < 1e-9
    assert r.q[-1, 0] - S0 > 0.04  # it moved the mass towards the reference


@pytest.mark.parametrize("change, match", [
    (("q:slide.d", "q:slide.x"), (r"analyses\[0\]\.controllers\[0\]\.measured: co-simulation: "
                                 r"signal 'q:slide\.x'")),
    (("output: lift", "output: lfit"), (r"analyses\[0\]\.controllers\[0\]\.output: "
                                       r"Simulator: input 'lfit'")),
    (("kp: 20.0", "kp: -2.0"), r"analyses\.0\.dynamic\.controllers\.0\.kp|controllers\[0\]\.kp"),
])
def test_a_bad_controller_is_named_at_its_line(tmp_path, change, match):
    from pipeline.workflow import run_workflow

    with pytest.raises(ConfigError, match=r"lift\.yaml:\d+: .*" + match):
        run_workflow(_workflow(tmp_path, CONTROLLER.replace(*change)),
                     out_root=tmp_path / "out")
