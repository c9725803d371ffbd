"""simulate(): closed-loop runs without drift, partial histories on failure, result files."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "dynamics"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))
from eom_models import flexible_double_pendulum, flexible_four_bar

from pipeline.core.errors import ConfigError, SolverError
from pipeline.dynamics import System
from pipeline.kinematics import assemble
from pipeline.solver import simulate


def _rigid_four_bar():
    s = flexible_four_bar(n_modes=0).system
    return s, assemble(s.mechanism, s.mechanism.q_initial).q


@pytest.mark.parametrize("formulation", ["dae", "partitioned"])
def test_four_bar_keeps_closure_for_10_s(formulation):
    s, q0 = _rigid_four_bar()
    qd0 = np.zeros_like(q0)
    qd0[0] = 3.0  # crank spin; the others follow from the loop
    r = simulate(s, q0, qd0, (0.0, 10.0), np.linspace(0, 10, 201), rtol=1e-9, atol=1e-9,
                 progress=False, formulation=formulation)
    assert r.formulation == formulation
    assert abs(r.qd[0, 0] - 3.0) < 1e-12  # the given rate is honoured
    assert r.success, r.message
    assert r.t[-1] == 10.0 and r.closure_residual.shape == (201,)
    assert r.closure_residual.max() < 1e-10, r.closure_residual.max()
    E = r.energies["total"]
    assert np.abs(E - E[0]).max() < 1e-6 * np.abs(r.energies["kinetic"]).max()
    assert np.ptp(r.q[:, 0]) > 1.0  # it moved


@dataclass(frozen=True)
class _Breaks:
    """Force that fails at t_fail: raises, or returns NaN (step-size collapse)."""

    t_fail: float
    nan: bool = False
    name: str = "breaker"
    conservative = False

    def generalized_force(self, system, tree, q, qd, t):
        if t > self.t_fail:
            if self.nan:
                return np.full(q.shape, np.nan)
            raise SolverError(f"force '{self.name}' failed at t = {t:.4f} s")
        return np.zeros_like(q)

    def potential_energy(self, system, tree, q):
        return 0.0


@pytest.mark.parametrize("nan", [False, True])
@pytest.mark.parametrize("method", ["DOP853", "Radau", "BDF"])
def test_failure_returns_partial_history(nan, method):
    base = flexible_double_pendulum(n_modes=1).system
    s = System(base.mechanism, base.bodies, base.gravity, forces=(_Breaks(0.3, nan),))
    q0 = np.zeros(s.mechanism.n)
    r = simulate(s, q0, q0, (0.0, 1.0), np.linspace(0, 1, 21), method=method, progress=False)
    assert not r.success and r.status == -1
    assert ("failed" in r.message) and ("t =" in r.message)
    assert 0 < r.t.size < 21 and r.t[-1] <= 0.3 + 1e-9 and r.n_steps > 0
    assert r.q.shape == (r.t.size, s.mechanism.n) and np.all(np.isfinite(r.q))


def test_bad_arguments_raise():
    s = flexible_double_pendulum(n_modes=1).system
    q0 = np.zeros(s.mechanism.n)
    with pytest.raises(ConfigError, match="method"):
        simulate(s, q0, q0, (0, 1), method="euler", progress=False)
    with pytest.raises(ConfigError, match="t_span"):
        simulate(s, q0, q0, (1, 0), progress=False)
    with pytest.raises(ConfigError, match="q0"):
        simulate(s, q0[:-1], q0, (0, 1), progress=False)


@pytest.mark.parametrize("method", ["DOP853", "Radau"])
def test_integrators_agree_on_a_flexible_run(method):
    s = flexible_double_pendulum(n_modes=2).system
    q0 = np.zeros(s.mechanism.n)
    te = np.linspace(0, 0.3, 4)
    ref = simulate(s, q0, q0, (0, 0.3), te, rtol=1e-11, atol=1e-11, progress=False)
    r = simulate(s, q0, q0, (0, 0.3), te, method=method, rtol=1e-8, atol=1e-8, progress=False)
    assert r.success, r.message
    assert np.abs(r.q - ref.q).max() < 1e-5


def test_result_files_round_trip(tmp_path):
    s = flexible_double_pendulum(n_modes=1).system
    q0 = np.zeros(s.mechanism.n)
    r = simulate(s, q0, q0, (0, 0.1), np.linspace(0, 0.1, 5), progress=False)
    p = r.save_npz(tmp_path / "run.npz")
    d = np.load(p)
    assert np.array_equal(d["q"], r.q) and np.array_equal(d["energy_total"], r.energies["total"])
    assert list(d["coordinates"]) == list(r.coordinates) and bool(d["success"])
    r.save_csv(tmp_path / "run.csv")
    rows = np.loadtxt(tmp_path / "run.csv", delimiter=",", skiprows=2)
    assert rows.shape == (5, 1 + 3 * s.mechanism.n + 7 + 1)
    assert np.allclose(rows[:, 1:1 + s.mechanism.n], r.q, rtol=0, atol=0)


@pytest.mark.parametrize("method", ["DOP853", "Radau"])
def test_position_failure_in_a_trial_stage_rejects_the_step(monkeypatch, method):
    """A trial state the loops cannot reach (here: injected once, at the first evaluation past
    t = 0.1 s) makes the integrator retry a shorter step instead of ending the run."""
    import pipeline.solver.integrate as integ
    from pipeline.kinematics.failures import ClosureError

    s = flexible_double_pendulum(n_modes=1).system
    q0 = np.zeros(s.mechanism.n)
    te = np.linspace(0, 0.3, 7)
    ref = simulate(s, q0, q0, (0, 0.3), te, method=method, rtol=1e-9, atol=1e-9,
                   progress=False)
    real, fired = integ.reduced_state, []

    def flaky(system, part, qI, qdI, t, guess, *drive):
        if t > 0.1 and not fired:
            fired.append(t)
            raise ClosureError("injected", "L1", "J", np.zeros(6), guess)
        return real(system, part, qI, qdI, t, guess, *drive)

    monkeypatch.setattr(integ, "reduced_state", flaky)
    r = simulate(s, q0, q0, (0, 0.3), te, method=method, rtol=1e-9, atol=1e-9,
                 progress=False)
    assert fired and r.success, r.message
    assert np.abs(r.q - ref.q).max() < 1e-6


def test_a_trial_stage_closed_far_away_does_not_steer_the_run(monkeypatch):
    """One trial stage of the partitioned run comes back closed three turns away (the wrist
    angle wrapped by -6 pi: a far Newton's legitimate answer). The runs used to keep every
    evaluation as the next guess, so the following ones continued from there and the run
    ended 6 pi (18.85 rad) off, marked ok; now every position Newton starts from the last
    accepted state and the run equals the undisturbed one."""
    import dataclasses

    from dyn2_models import rigid_bar
    from kin_models import slider_crank

    import pipeline.solver.integrate as integ
    from pipeline.dynamics import BodyMass
    from pipeline.kinematics.initial import initial_positions

    r_, l_ = 0.2, 0.6
    m = slider_crank(r_, l_, 0.0, theta0=0.3)
    s = System(m, {"crank": rigid_bar(1.0, r_), "rod": rigid_bar(2.0, l_),
                   "slider": BodyMass.rigid(3.0, [0, 0, 0], 0.01 * np.eye(3))},
               gravity=[0.0, -9.81, 0.0])
    q0 = initial_positions(m, m.q_initial, given={"crank.theta": 0.3})
    qd0 = np.zeros(m.n)
    qd0[0] = 20.0
    te = np.linspace(0.0, 0.5, 51)
    ref = simulate(s, q0, qd0, (0.0, 0.5), te, formulation="partitioned", progress=False)
    real, fired = integ.reduced_state, []

    def far(system, part, qI, qdI, t, guess, *drive):
        st = real(system, part, qI, qdI, t, guess, *drive)
        if t > 0.2 and not fired:
            q = st.q.copy()
            q[m.index("wrist.theta")] -= 6.0 * np.pi
            st = dataclasses.replace(st, q=q)
            fired.append(t)
        return st

    monkeypatch.setattr(integ, "reduced_state", far)
    r = simulate(s, q0, qd0, (0.0, 0.5), te, formulation="partitioned", progress=False)
    assert fired and r.verdict == "ok", r.report
    assert np.abs(r.q - ref.q).max() < 1e-9


def test_outputs_sharing_a_step_match_a_tighter_run():
    """The partitioned run interpolates each step once for all the outputs inside it.
    A dense grid (about 150 outputs per step) agrees with a run 1e5 times tighter on a
    sparse grid to the loose run's own error, and conserves energy; an interpolant reused
    from another step would be off by radians."""
    s, q0 = _rigid_four_bar()
    qd0 = np.zeros_like(q0)
    qd0[0] = 3.0
    dense_t = np.linspace(0.0, 1.0, 2001)
    dense = simulate(s, q0, qd0, (0.0, 1.0), dense_t, rtol=1e-6, atol=1e-8, progress=False,
                     formulation="partitioned")
    ref = simulate(s, q0, qd0, (0.0, 1.0), dense_t[::100], rtol=1e-11, atol=1e-12,
                   progress=False, formulation="partitioned")
    assert dense.success and ref.success
    assert dense.n_steps < dense_t.size / 50  # many outputs share each step
    np.testing.assert_allclose(dense.q[::100], ref.q, rtol=0, atol=1e-4)
    E = dense.energies["total"]
    assert np.abs(E - E[0]).max() < 1e-4 * np.abs(dense.energies["kinetic"]).max()
