"""Energy balance with force elements: a spring-damper between the links of the
flexible double pendulum and a joint spring-damper (potentials and dissipation)."""

from __future__ import annotations

import numpy as np
import pytest
from eom_models import flexible_double_pendulum

from pipeline.dynamics import System
from pipeline.dynamics.forces import JointSpringDamper, SpringDamper
from pipeline.solver import simulate


def _run(forces):
    base = flexible_double_pendulum(n_modes=2).system
    s = System(base.mechanism, base.bodies, base.gravity, forces=forces)
    q0 = np.zeros(s.mechanism.n)
    return simulate(s, q0, q0, (0.0, 0.6), np.linspace(0, 0.6, 31), rtol=1e-10, atol=1e-10,
                    progress=False)


def _drift(r):
    E = r.energies["total"]
    return float(np.abs(E - E[0]).max() / np.abs(r.energies["kinetic"]).max())


@pytest.mark.slow  # 10 s: kept out of the default run's budget, run by .ci/run
def test_springs_conserve_and_dampers_close_the_balance():
    spring = SpringDamper("s", ("ground", "body"), ("link2", "C"), stiffness=40.0,
                          free_length=1.0)
    joint = JointSpringDamper("js", "j2.theta", stiffness=5.0, free_value=0.3)
    r = _run((spring, joint))
    assert r.success, r.message
    assert np.ptp(r.energies["forces"]) > 0.05 * np.abs(r.energies["kinetic"]).max()
    assert r.energies["dissipated"][-1] == 0.0 and _drift(r) < 1e-6
    damped = _run((SpringDamper("s", ("ground", "body"), ("link2", "C"), stiffness=40.0,
                                free_length=1.0, damping=3.0),
                   JointSpringDamper("js", "j2.theta", stiffness=5.0, free_value=0.3,
                                     damping=0.5)))
    assert damped.success, damped.message
    assert damped.energies["dissipated"][-1] > 0.05 * np.abs(damped.energies["kinetic"]).max()
    assert _drift(damped) < 1e-6
