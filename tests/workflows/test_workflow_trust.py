"""What a workflow says about its runs: initial values honoured or refused with file:line and
path, suspect runs named in the manifest and on the console, the machine report of
``validate --build``."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from test_workflow_run import FOURBAR, _rocker_closed_form, _write

from pipeline.core.errors import ConfigError
from pipeline.workflow import load_workflow, run_workflow
from pipeline.workflow.build import build_machine

FREE = FOURBAR.replace("""drivers:
  JA.theta: {type: ramp, t0: 0.0, rate: 6.283185307179586, v0: 1.0}
""", "").replace("""    type: kinematic
    t_end: 1.0
    outputs: 73
    markers: [coupler.C]
    cases:
      - {label: slow, set: {}}
      - {label: fast, set: {drivers.JA.theta.rate: 12.566370614359172}}""", """    type: dynamic
    t_end: 0.5
    outputs: 11""")


def test_initial_values_are_honoured(tmp_path):
    text = FREE + "initial:\n  coordinates: {JA.theta: 0.8}\n  velocities: {JA.theta: 4.0}\n"
    m = build_machine(load_workflow(_write(tmp_path, text)), tmp_path / "links")
    mech = m.mechanism
    assert m.q0[mech.index("JA.theta")] == 0.8 and m.qd0[mech.index("JA.theta")] == 4.0
    phi, _ = _rocker_closed_form(np.array([0.8]))
    assert abs(np.angle(np.exp(1j * (m.q0[mech.index("JD.theta")] - phi[0])))) < 1e-10


def test_initial_values_that_cannot_be_honoured_are_named(tmp_path):
    text = FREE + "initial:\n  velocities: {JA.theta: 4.0, JD.theta: 9.0}\n"
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        build_machine(load_workflow(path), tmp_path / "links")
    msg = str(exc.value)
    assert "fourbar.yaml:" in msg and "initial.velocities" in msg and "JD.theta" in msg


def test_a_suspect_run_says_so_in_the_manifest_and_on_the_console(tmp_path):
    """A tight energy limit the explicit run cannot meet at a loose tolerance: 'suspect',
    with the figure and the time; the CLI prints it and exits 1."""
    text = FREE + "initial:\n  velocities: {JA.theta: 4.0}\n"
    text = text.replace("    outputs: 11", "    outputs: 11\n    rtol: 1.0e-3\n"
                        "    checks: {energy: 1.0e-9}")
    path = _write(tmp_path, text)
    res = run_workflow(path, out_root=tmp_path / "out", cache_dir=tmp_path / "links")
    man = json.loads((res.out_dir / "manifest.json").read_text())
    assert man["status"] == "suspect"
    (case,) = man["analyses"]["turn"]
    assert case["verdict"] == "suspect" and "energy balance off by" in case["warnings"][0]
    cli = subprocess.run([sys.executable, "-m", "pipeline", "run", str(path), "--out",
                          str(tmp_path / "out2")], capture_output=True, text=True,
                         check=False)
    assert cli.returncode == 1 and "SUSPECT" in cli.stdout and "energy balance" in cli.stdout
    tight = run_workflow(_write(tmp_path, text.replace("    rtol: 1.0e-3\n", "")),
                      out_root=tmp_path / "out3", cache_dir=tmp_path / "links")
    assert tight.manifest["status"] == "suspect"  # 1e-9 of the exchanged energy is too tight
    loose = text.replace("checks: {energy: 1.0e-9}", "checks: {energy: 1.0e-3}").replace(
        "    rtol: 1.0e-3\n", "")
    assert run_workflow(_write(tmp_path, loose), out_root=tmp_path / "out4",
                        cache_dir=tmp_path / "links").manifest["status"] == "ok"


def test_validate_build_reports_the_machine(tmp_path):
    path = _write(tmp_path, FREE)
    out = subprocess.run([sys.executable, "-m", "pipeline", "validate", str(path), "--build"],
                         capture_output=True, text=True, cwd=tmp_path, check=False)
    assert out.returncode == 0, out.stderr
    text = out.stdout
    assert "DOF 1 = 4 coordinates - 3 independent closure constraints" in text
    assert "redundant constraints (3" in text and "position z" in text
    assert "independent coordinates: ['" in text and "initial energy: kinetic 0 J" in text


def test_a_run_names_its_redundant_constraints(tmp_path, caplog):
    """As ADAMS does at verification: a planar loop built in 3D has three redundant rows."""
    with caplog.at_level("WARNING", logger="pipeline.workflow.run"):
        run_workflow(_write(tmp_path, FREE), out_root=tmp_path / "out",
                     cache_dir=tmp_path / "links")
    (msg,) = [r.getMessage() for r in caplog.records if "redundant" in r.getMessage()]
    assert "3 redundant closure constraints" in msg and "position z" in msg
