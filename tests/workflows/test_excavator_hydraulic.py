"""workflows/excavator_hydraulic.yaml in --quick mode: the excavator's dig cycle driven
through its valves by PID stroke controllers, checked against the independent planar
model of test_excavator.py: the cylinders' hydraulic forces (p_a A_a - p_b A_b less the
seal friction) are the forces that hold the front statically at the cylinder lengths the
run reaches (dV/dd of the hand-written potential; the cycle is slow), and the controllers
follow excavator.yaml's stroke tables."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_excavator import PlanarExcavator

from pipeline.kinematics.drivers import SmoothStep

pytestmark = pytest.mark.gmsh

CYLINDERS = {"boom_cyl": ("BCYL.d", 1.1948215, 1.4948215),
             "stick_cyl": ("SCYL.d", 1.5021715, 1.2021715)}


@pytest.fixture(scope="module")
def run(quick_run):
    return quick_run("excavator_hydraulic")


def test_the_valves_drive_the_cycle_and_the_pressures_carry_the_planar_models_forces(run):
    assert run.manifest["status"] == "ok", run.manifest["analyses"]
    r = run.result("dig", "")
    machine = run.machines[""]
    model = PlanarExcavator(machine.parts["boom"].reduced)
    forces = {f.name: f for f in machine.system.forces}
    d = {}
    for name, (coord, v0, v1) in CYLINDERS.items():
        i = r.coordinates.index(coord)
        d[name] = r.q[:, i]
        # the controller follows the stroke table, a P-dominated loop lagging by about the
        # stroke rate over its velocity gain (kp times the valve's flow gain over the area:
        # ~2 1/s, kept below 2 zeta_h omega_h of the oil column's 7 Hz ringing)
        goal = np.array([SmoothStep(0.0, 6.0, v0, v1).value(t) for t in r.t])
        assert np.abs(r.q[:, i] - goal).max() < 0.03, name
        assert abs(r.q[-1, i] - v0) > 0.01  # it moved
    held = np.array([model.forces(a, b) for a, b in zip(d["boom_cyl"], d["stick_cyl"])])
    for k, (name, (coord, _, _)) in enumerate(CYLINDERS.items()):
        f = forces[name]
        aa, ab = f.areas
        pa, pb = r.states[f"{name}.p_a"][1], r.states[f"{name}.p_b"][1]
        rate = r.qd[:, r.coordinates.index(coord)]
        hydraulic = pa * aa - pb * ab - f.viscous_friction * rate
        # at rest at the start (the held pressures); then the front rings a little on its
        # oil columns (7 Hz), a few kN either way, about the static forces
        scale = np.abs(held).max()  # the boom cylinder's ~100 kN
        assert abs(hydraulic[0] - held[0, k]) < 0.01 * abs(held[0, k]), name
        assert np.abs(hydraulic - held[:, k]).max() < 0.06 * scale, name
        assert abs(np.mean(hydraulic - held[:, k])) < 0.015 * scale, name
    assert (run.out_dir / "pressures.png").exists() and (run.out_dir / "dig.csv").exists()
