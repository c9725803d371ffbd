"""A hydraulic cylinder written in a workflow: the same run as the Python API's, its chamber
pressures in the exports and plots (``state:`` series), a misspelt state named before any
analysis runs, and analyses that cannot carry the pressures refused at their line."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "solver"))
from test_hydraulic_cylinder import PB0, S0, _lift

from pipeline.core.errors import ConfigError
from pipeline.kinematics.drivers import SmoothStep
from pipeline.solver import simulate
from pipeline.workflow import run_workflow

LIFT = f"""\
name: lift
gravity: [0, 0, -9.81]
links:
  ground:
    type: ground
    frames:
      rail: {{origin: [0, 0, 0]}}
      mount: {{origin: [0, 0, -1.0]}}
  mass:
    type: rigid
    mass: 500.0
    com: [0, 0, 0]
    inertia: [1, 1, 1, 0, 0, 0]
    frames: {{eye: {{origin: [0, 0, 0]}}}}
joints:
  - {{name: slide, type: prismatic, parent: ground.rail, child: mass.eye, initial: [{S0}]}}
forces:
  - name: lift
    type: hydraulic_cylinder
    marker_a: ground.mount
    marker_b: mass.eye
    bore: 0.08
    rod: 0.04
    stroke: 0.5
    length_retracted: 1.0
    supply_pressure: 100.0e5
    nominal_flow: 1.0e-3
    initial_pressures: [hold, {PB0}]   # the piston side holds the mass at rest
    command: {{type: smooth_step, t0: 0.0, t1: 0.2, v0: 0.0, v1: 0.6}}
analyses:
  - name: raise
    type: dynamic
    t_end: 0.4
    outputs: 41
    method: generalized_alpha
    step: 5.0e-4
    rtol: 1.0e-4
    atol: 1.0e-8
outputs:
  plots:
    - {{name: pressures, analysis: raise, series: ["state:lift.p_a", "state:lift.p_b"]}}
  exports: {{csv: true, npz: true}}
"""


def _write(tmp_path, text=LIFT) -> Path:
    p = tmp_path / "lift.yaml"
    p.write_text(text)
    return p


def test_the_workflow_runs_the_cylinder_as_the_python_api_does(tmp_path):
    res = run_workflow(_write(tmp_path), out_root=tmp_path / "out")
    r = res.result("raise", "")
    assert r.verdict == "ok", r.warnings
    system, _ = _lift(SmoothStep(0.0, 0.2, 0.0, 0.6))
    ref = simulate(system, np.array([S0]), np.zeros(1), (0.0, 0.4), np.linspace(0, 0.4, 41),
                   method="generalized_alpha", step=5e-4, rtol=1e-4, atol=1e-8,
                   progress=False)
    assert np.abs(r.q - ref.q).max() < 1e-12
    unit, pa = r.states["lift.p_a"]
    assert unit == "Pa" and np.abs(pa - ref.state("lift.p_a")).max() < 1e-6
    rows = list(csv.DictReader((res.out_dir / "raise.csv").open()))
    assert float(rows[-1]["state:lift.p_b_Pa"]) == pytest.approx(ref.state("lift.p_b")[-1])
    assert (res.out_dir / "pressures.png").stat().st_size > 0
    assert "state:lift.p_a" in np.load(res.out_dir / "raise.npz").files


def test_a_misspelt_state_is_named_before_anything_runs(tmp_path):
    bad = LIFT.replace('"state:lift.p_b"', '"state:lift.p_c"')
    with pytest.raises(ConfigError, match=r"outputs\.plots\[0\].*state:lift\.p_c.*'lift\.p_a'"):
        run_workflow(_write(tmp_path, bad), out_root=tmp_path / "out")


def test_a_static_analysis_cannot_carry_the_pressures(tmp_path):
    text = LIFT.replace("  - name: raise\n    type: dynamic",
                        "  - name: hold\n    type: static\n  - name: raise\n    type: dynamic")
    with pytest.raises(ConfigError, match=r"lift\.yaml:\d+: analyses\[0\]\.type: force "
                                          r"element\(s\) \['lift'\] have states.*this one is "
                                          r"static"):
        run_workflow(_write(tmp_path, text), out_root=tmp_path / "out", outputs=False)


@pytest.mark.parametrize("start", ["initial", "static"])
def test_a_linearised_analysis_rings_at_the_oil_column_frequency(tmp_path, start):
    """The pressures held at their start values (the hold pressure found at the initial
    pose): the linearised frequency is the closed-valve oil column's closed form."""
    from test_hydraulic_cylinder import AA, AB, BETA, MASS, STROKE, VA0, VB0

    text = LIFT.replace("analyses:\n", f"analyses:\n  - {{name: ring, type: linearised, "
                                       f"start: {start}, count: 3}}\n")
    res = run_workflow(_write(tmp_path, text), out_root=tmp_path / "out", outputs=False)
    r = res.result("ring", "")
    assert r.success and r.verdict == "ok", (r.message, r.warnings)
    omega = np.sqrt(BETA * (AA ** 2 / (VA0 + AA * S0) + AB ** 2 / (VB0 + AB * (STROKE - S0)))
                    / MASS)
    np.testing.assert_allclose(r.extra["omega"], [omega], rtol=1e-6)
    assert list(r.extra["z_names"]) == ["lift.p_a", "lift.p_b"]


def test_a_dynamic_run_may_start_from_the_statics_the_held_pressures_give(tmp_path):
    """``start: static`` with the pressures held at their start values: the rigid mass is
    already where the hold pressure holds it, so the run equals the one from its initial
    state."""
    text = LIFT.replace("    atol: 1.0e-8\n", "    atol: 1.0e-8\n    start: static\n")
    assert "start: static" in text
    res = run_workflow(_write(tmp_path, text), out_root=tmp_path / "a", outputs=False)
    ref = run_workflow(_write(tmp_path), out_root=tmp_path / "b", outputs=False)
    r, r0 = res.result("raise", ""), ref.result("raise", "")
    assert r.verdict == "ok", r.warnings
    np.testing.assert_allclose(r.q, r0.q, atol=1e-9)


PID_COMMAND = ("    command:\n      pid:\n        reference: {type: smooth_step, t0: 0.0, t1: 0.3, "
               f"v0: {S0}, v1: {S0 + 0.05}}}\n        kp: 20.0\n        ki: 40.0\n"
               "        kd: 0.5\n        measured: slide.d\n")


def _with_pid(text=LIFT, command=PID_COMMAND):
    return text.replace("    command: {type: smooth_step, t0: 0.0, t1: 0.2, v0: 0.0, v1: 0.6}\n",
                        command)


def test_a_pid_commanded_cylinder_runs_as_the_python_api_does(tmp_path):
    from pipeline.dynamics.forces.hydraulics import PID

    text = _with_pid().replace('"state:lift.p_b"]', '"state:lift.p_b", "state:lift.pid"]')
    res = run_workflow(_write(tmp_path, text), out_root=tmp_path / "out")
    r = res.result("raise", "")
    pid = PID(SmoothStep(0.0, 0.3, S0, S0 + 0.05), kp=20.0, ki=40.0, kd=0.5,
              measured="slide.d")
    system, _ = _lift(pid)
    ref = simulate(system, np.array([S0]), np.zeros(1), (0.0, 0.4), np.linspace(0, 0.4, 41),
                   method="generalized_alpha", step=5e-4, rtol=1e-4, atol=1e-8,
                   progress=False)
    assert r.verdict == ref.verdict and np.abs(r.q - ref.q).max() < 1e-12
    assert r.q[-1, 0] - S0 > 0.03  # the controller moved it towards its reference
    assert np.abs(r.states["lift.pid"][1] - ref.state("lift.pid")).max() < 1e-12


@pytest.mark.parametrize("command, match", [
    (PID_COMMAND.replace("kp: 20.0", "kq: 20.0"),
     r"forces\[0\]\.command\.pid\.kq: unknown field of a PID"),
    (PID_COMMAND.replace("slide.d", "slide.x"),
     r"forces\[0\]\.command\.pid\.measured: coordinate 'slide\.x' does not exist"),
    (PID_COMMAND.replace("kp: 20.0", "kp: -2.0"), r"forces\[0\]\.command\.pid: PID: kp"),
    (PID_COMMAND.replace("        kp: 20.0\n", ""), r"forces\[0\]\.command\.pid: missing field 'kp'"),
    (PID_COMMAND.replace("slide.d", "p_a"),
     r"forces\[0\]\.command\.pid: PID: kd: a loop on the pressure p_a has no derivative"),
    (PID_COMMAND.replace("slide.d", "marker:mass.nose:z"),
     r"forces\[0\]\.command\.pid\.measured: link 'mass': frame 'nose' does not exist"),
    (PID_COMMAND.replace("slide.d", "marker:mass.body:up"),
     r"forces\[0\]\.command\.pid\.measured: PID: measured: marker: expected 'link\.frame:x"),
])
def test_a_bad_pid_is_named_at_its_line(tmp_path, command, match):
    with pytest.raises(ConfigError, match=r"lift\.yaml:\d+: " + match):
        run_workflow(_write(tmp_path, _with_pid(command=command)), out_root=tmp_path / "out")


def test_a_pid_on_a_marker_runs_as_the_one_on_its_coordinate(tmp_path):
    """The lift's mass moves its body origin along ground z by its slide coordinate."""
    text = _with_pid(command=PID_COMMAND.replace("slide.d", "marker:mass.body:z"))
    r = run_workflow(_write(tmp_path, text), out_root=tmp_path / "a", outputs=False)
    ref = run_workflow(_write(tmp_path, _with_pid()), out_root=tmp_path / "b", outputs=False)
    assert np.abs(r.result("raise", "").q - ref.result("raise", "").q).max() < 1e-12


def test_a_pid_may_measure_a_chamber_pressure(tmp_path):
    from pipeline.workflow import build_machine, load_workflow

    command = PID_COMMAND.replace("slide.d", "p_a").replace("        kd: 0.5\n", "")
    wf = load_workflow(_write(tmp_path, _with_pid(command=command)))
    cyl = build_machine(wf, tmp_path / "links").system.forces[0]
    assert cyl.command.measured == "p_a" and cyl.measured_index(None) == -2


def test_air_and_a_counterbalance_valve_are_written_in_the_workflow(tmp_path):
    """``air_content`` (dissolving), and ``counterbalance: {...}`` (with its spool's lag,
    or its spool on its spring) build the element the Python API builds; a bad valve field is named at its line."""
    from pipeline.dynamics.forces.hydraulics import CounterbalanceValve
    from pipeline.workflow.build import build_machine
    from pipeline.workflow.load import load_workflow

    extra = ("    air_content: 0.01\n"
             "    air_dissolved_pressure: 150.0e5\n"
             "    counterbalance: {side: a, setting: 250.0e5, pilot_ratio: 4.0}\n")
    text = LIFT.replace("    nominal_flow: 1.0e-3\n", "    nominal_flow: 1.0e-3\n" + extra)
    m = build_machine(load_workflow(_write(tmp_path, text)), tmp_path / "links")
    cyl = m.system.forces[0]
    assert cyl.air_content == 0.01 and cyl.air_dissolved_pressure == 150e5
    assert cyl.STATES == ("p_a", "p_b", "p_c")
    assert cyl.counterbalance == CounterbalanceValve("a", 250e5, 4.0)
    bad = text.replace("pilot_ratio: 4.0", "pilot_ration: 4.0")
    with pytest.raises(ConfigError, match=r"lift\.yaml:\d+: forces\[0\].*counterbalance: "
                                          r"unknown field 'pilot_ration'"):
        build_machine(load_workflow(_write(tmp_path, bad)), tmp_path / "links")
    lagged = text.replace("pilot_ratio: 4.0", "pilot_ratio: 4.0, time_constant: 0.03")
    m = build_machine(load_workflow(_write(tmp_path, lagged)), tmp_path / "links")
    assert m.system.forces[0].STATES == ("p_a", "p_b", "p_c", "a_c")
    sprung = text.replace("pilot_ratio: 4.0",
                          "pilot_ratio: 4.0, spool_frequency: 12.0, spool_damping: 0.3")
    m = build_machine(load_workflow(_write(tmp_path, sprung)), tmp_path / "links")
    assert m.system.forces[0].STATES == ("p_a", "p_b", "p_c", "a_c", "v_c")
    assert m.system.forces[0].counterbalance.spool_damping == 0.3
    bad = text.replace("pilot_ratio: 4.0", "pilot_ratio: 4.0, time_constant: -0.03")
    with pytest.raises(ConfigError, match=r"lift\.yaml:\d+: forces\[0\].*counterbalance: "
                                          r"time_constant: expected seconds > 0"):
        build_machine(load_workflow(_write(tmp_path, bad)), tmp_path / "links")


def test_a_static_analysis_traps_the_oil_behind_the_closed_valve(tmp_path):
    """``trapped: true``: the pressures start at their start values and follow the
    stroke; the pose and pressures are the Python API's (tests/solver/
    test_hydraulic_trapped.py has the closed form)."""
    from pipeline.dynamics import static_equilibrium

    text = LIFT.replace(f"initial_pressures: [hold, {PB0}]", "initial_pressures: [10.0e5, 10.0e5]")
    text = text.replace("  - name: raise\n    type: dynamic",
                        "  - name: hold\n    type: static\n    trapped: true\n"
                        "  - name: raise\n    type: dynamic")
    res = run_workflow(_write(tmp_path, text), out_root=tmp_path / "out", outputs=False)
    r = res.result("hold", "")
    assert r.success, r.message
    system, _ = _lift(SmoothStep(0.0, 0.2, 0.0, 0.6), initial_pressures=(10e5, 10e5))
    ref = static_equilibrium(system, np.array([S0]), z=np.array([10e5, 10e5]), trapped=True)
    assert abs(r.q[0, 0] - ref.q[0]) < 1e-12 and S0 - ref.q[0] > 1e-4
    unit, pa = r.states["lift.p_a"]
    assert unit == "Pa" and pa[0] == pytest.approx(ref.z[0], rel=1e-12)
    opened = text.replace("v0: 0.0, v1: 0.6}", "v0: 0.3, v1: 0.6}")  # open at t = 0
    with pytest.raises(ConfigError, match=r"analyses\[0\]\.trapped: force element 'lift': "
                                          r"trapped: its valve is open"):
        run_workflow(_write(tmp_path, opened), out_root=tmp_path / "out2", outputs=False)
