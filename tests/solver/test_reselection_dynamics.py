"""Re-selection of the independent coordinates during a run: a free five-bar (2 DOF)
under gravity carries its initial free pair into a toggle (their dependent block
becomes singular, so the run would stop there); the solver re-selects and goes on."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))
from kin_models import five_bar

from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.partition import _rcond, partition_system
from pipeline.kinematics import assemble, closure, solve_velocity
from pipeline.solver import simulate


def test_five_bar_runs_through_toggles_of_its_first_partition():
    m = five_bar()
    bodies = {n: BodyMass.rigid(1.0 + 0.3 * i, [0.3, 0, 0], np.diag([0.01, 0.01, 0.02]))
              for i, n in enumerate(["c1", "b2", "b3", "c4"])}
    s = System(m, bodies, gravity=[0.0, -9.81, 0.0])
    a = assemble(m, driven=["J1.theta", "J5.theta"])
    qd = np.zeros(m.n)
    qd[0], qd[4] = 6.0, -2.0
    qd0 = solve_velocity(a.closure.J, a.partition, qd)
    r = simulate(s, a.q, qd0, (0.0, 1.0), np.linspace(0, 1, 101), rtol=1e-9, atol=1e-9,
                 progress=False, formulation="partitioned")
    assert r.success, r.message
    assert len(r.reselections) >= 1
    first = partition_system(s, a.q).kin  # the initial choice degenerates on the way
    assert min(_rcond(m, closure(m, q).J, first) for q in r.q) < 1e-2
    assert r.closure_residual.max() < 1e-10
    E = r.energies["total"]
    assert np.abs(E - E[0]).max() < 1e-7 * np.abs(r.energies["kinetic"]).max()
