"""Energy conservation and the damped energy balance of transient runs (DOP853)."""

from __future__ import annotations

import numpy as np
import pytest
from eom_models import flexible_double_pendulum, flexible_four_bar

from pipeline.dynamics.energy import kinetic_energy
from pipeline.kinematics import evaluate_tree
from pipeline.solver import simulate


def _drift(r):
    E = r.energies["total"]
    return float(np.abs(E - E[0]).max() / np.abs(r.energies["kinetic"]).max())


@pytest.mark.parametrize("second_order", [False, True])
def test_kinetic_energy_equals_the_link_by_link_form(second_order):
    """T = 1/2 q'^T M q' against T summed over the links from their pose rates A'
    (tests/dynamics/inertia_numpy.py, which never forms M)."""
    import inertia_numpy

    s = flexible_double_pendulum(second_order=second_order).system
    rng = np.random.default_rng(5)
    q, qd = rng.standard_normal(s.mechanism.n), rng.standard_normal(s.mechanism.n)
    T = kinetic_energy(s, evaluate_tree(s.mechanism, q, qd), q, qd)
    ref = inertia_numpy.kinetic_energy(s, evaluate_tree(s.mechanism, q, qd), q, qd)
    assert abs(T - ref) <= 1e-13 * abs(ref)


@pytest.mark.parametrize("second_order", [False, True])
def test_flexible_double_pendulum_conserves_energy_from_horizontal(second_order):
    """Also with links whose mass moves towards their reference as they bend (their
    second-order first moment: geometric stiffening by accelerations and gravity, which
    must come with its energy; stiffer links, where the random moments would otherwise
    drive them far beyond the linear range)."""
    s = flexible_double_pendulum(n_modes=3, second_order=second_order,
                                 k_scale=2000.0 if second_order else 200.0).system
    q0 = np.zeros(s.mechanism.n)
    r = simulate(s, q0, q0, (0.0, 2.0), np.linspace(0, 2, 101), rtol=1e-10, atol=1e-10,
                 progress=False)
    assert r.success, r.message
    assert np.abs(r.q[:, 2:]).max() > 0.1  # the links really flex
    drift = _drift(r)
    assert drift < 1e-5, drift
    assert r.energies["dissipated"][-1] == 0.0


def test_modal_damping_dissipation_closes_the_balance():
    s = flexible_double_pendulum(n_modes=3, zeta=0.05).system
    q0 = np.zeros(s.mechanism.n)
    r = simulate(s, q0, q0, (0.0, 2.0), np.linspace(0, 2, 101), rtol=1e-10, atol=1e-10,
                 progress=False)
    assert r.success, r.message
    diss = r.energies["dissipated"]
    assert diss[-1] > 1e-3 * np.abs(r.energies["kinetic"]).max()  # damping did work
    assert np.all(np.diff(diss) >= -1e-12)  # and only removed energy
    drift = _drift(r)
    assert drift < 1e-5, drift


# the DAE case takes 8 s: kept out of the default run's budget, run by .ci/run
@pytest.mark.parametrize("formulation", [pytest.param("dae", marks=pytest.mark.slow),
                                         "partitioned"])
def test_flexible_closed_loop_conserves_energy(formulation):
    s = flexible_four_bar(n_modes=2).system
    q0 = s.mechanism.q_initial
    from pipeline.kinematics import assemble
    q0 = assemble(s.mechanism, q0).q
    r = simulate(s, q0, np.zeros_like(q0), (0.0, 0.5), np.linspace(0, 0.5, 26), rtol=1e-10,
                 atol=1e-10, progress=False, formulation=formulation)
    assert r.formulation == formulation
    assert r.success, r.message
    assert r.closure_residual.max() < 1e-10
    drift = _drift(r)
    assert drift < 1e-5, drift
