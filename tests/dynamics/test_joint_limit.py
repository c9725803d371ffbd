"""The joint limit (pipeline.dynamics.forces.limits): the element kind that is added by one
module, the worked example of docs/force_elements.md.

References built here, independent of the package's equations:
- a free slider that runs into the stop at v0 leaves it after half a period of the
  contact's damped oscillator, pi / omega_d, at v0 exp(-zeta omega_n pi / omega_d), and
  (undamped) with its energy back, having gone v0 / omega_n into the stop;
- the element's force and potential written by hand in numpy, Q = -dV/dq by central
  differences;
- the registry: the kind reaches the YAML vocabulary and the compiled dispatchers with no
  other module naming it, and broken registrations are refused.
"""

from __future__ import annotations

import types

import numpy as np
import pytest

from pipeline.core.errors import ConfigError
from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.forces import FORCES
from pipeline.dynamics.forces.base import Kernels
from pipeline.dynamics.forces.compiled import KERNELS, _registry, element_modules
from pipeline.dynamics.forces.limits import JointLimit, limit_force, limit_potential
from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
from pipeline.solver import simulate

MASS, K, V0, X0 = 2.0, 2.0e4, 0.8, -0.02


def _slider(**kw):
    """A 2 kg slider on a horizontal prismatic joint, no gravity, its stop at d = 0."""
    mech = build_mechanism([rigid_link("ground"), rigid_link("slider")],
                           [Joint("rail", "prismatic", "ground", "body", "slider", "body")])
    stop = JointLimit("stop", "rail.d", **{"upper": 0.0, "stiffness": K, **kw})
    return System(mech, {"slider": BodyMass.rigid(MASS, [0, 0, 0], np.eye(3))},
                  gravity=[0, 0, 0], forces=(stop,)), stop


def _bounce(damping, h):
    """(the run's verdict, the error of the slider's speed after the contact (m/s) and
    of its position (as a speed: times omega_n), and the deepest point (m), against the
    closed forms; omega_n)."""
    system, _ = _slider(damping=damping)
    wn = np.sqrt(K / MASS)
    zeta = damping / (2.0 * np.sqrt(K * MASS))
    wd = wn * np.sqrt(1.0 - zeta ** 2)
    t_out = -X0 / V0 + np.pi / wd
    te = np.linspace(0.0, t_out + 0.01, 401)
    res = simulate(system, np.array([X0]), np.array([V0]), (0.0, te[-1]), te,
                   method="generalized_alpha", step=h, rtol=1e-4, atol=1e-7,
                   progress=False)
    exit_speed = -V0 * np.exp(-zeta * wn * np.pi / wd)  # then it coasts
    late = te > t_out + 1e-3
    return (res.verdict, np.abs(res.qd[late, 0] - exit_speed).max(),
            np.abs(res.q[late, 0] - exit_speed * (te[late] - t_out)).max() * wn,
            res.q[:, 0].max(), wn)


def test_an_undamped_stop_returns_the_slider_with_its_energy():
    verdict, speed, position, deepest, wn = _bounce(0.0, 1e-4)
    assert verdict == "ok"
    assert max(speed, position) < 3e-5 * V0
    assert deepest == pytest.approx(V0 / wn, rel=1e-4)  # v0 / omega_n into the stop


def test_a_damped_stop_returns_the_slider_at_the_oscillators_restitution():
    """The damper's force jumps by c v0 as contact begins: first order in the step, and a
    step too coarse for it is reported by the run's own error estimate."""
    assert _bounce(40.0, 1e-4)[0] == "suspect"
    errors = []
    for h in (2.5e-5, 1.25e-5):
        verdict, speed, position, _, _ = _bounce(40.0, h)
        assert verdict == "ok"
        errors.append(max(speed, position))
    assert errors[1] < 3e-4 * V0, errors
    assert 1.6 < errors[0] / errors[1] < 2.6, errors  # first order


def test_the_force_and_potential_are_the_hand_written_law_and_q_is_minus_dv_dq():
    lower, upper, c = -0.3, 0.4, 15.0
    system, stop = _slider(lower=lower, upper=upper, damping=c)
    rng = np.random.default_rng(3)
    for q in (-0.5, -0.31, -0.2, 0.0, 0.39, 0.45, 1.0):
        qv, v = np.array([q]), np.array([rng.normal()])
        tree = evaluate_tree(system.mechanism, qv)
        x = q - upper if q > upper else (q - lower if q < lower else 0.0)
        damper = -c * v[0] if x != 0.0 else 0.0
        Q = stop.generalized_force(system, tree, qv, v, 0.0)
        assert Q[0] == pytest.approx(-K * x + damper, abs=1e-12)
        assert stop.nonconservative_force(system, tree, qv, v, 0.0)[0] == \
            pytest.approx(damper, abs=1e-12)
        assert stop.potential_energy(system, tree, qv) == pytest.approx(0.5 * K * x * x,
                                                                           abs=1e-12)
        assert stop.loads(system, tree, qv, v, 0.0) == ()  # through the joint
        eps = 1e-7
        V = [stop.potential_energy(system, evaluate_tree(system.mechanism, qv + s), qv + s)
             for s in (eps, -eps)]
        conservative = Q[0] - damper
        assert -(V[0] - V[1]) / (2 * eps) == pytest.approx(conservative, abs=1e-4 * K * eps
                                                          + 1e-6 * abs(conservative))


@pytest.mark.parametrize("kw, match", [
    ({"stiffness": -1.0}, "stiffness: expected a finite value >= 0"),
    ({"damping": float("nan")}, "damping: expected a finite value >= 0"),
    ({"upper": None}, "expected a lower or an upper limit"),
    ({"lower": 0.5}, "lower: expected below upper"),
    ({"lower": "low"}, "lower: expected a finite value or none"),
    ({"stiffness": True}, "stiffness: expected a finite value >= 0"),
])
def test_a_bad_limit_is_refused_naming_its_field(kw, match):
    with pytest.raises(ConfigError, match=match):
        _slider(**kw)


def test_the_kind_is_registered_by_its_own_module_only():
    assert FORCES["joint_limit"] is JointLimit
    assert KERNELS[JointLimit.KIND] == Kernels((JointLimit,), limit_potential,
                                               force=limit_force)
    assert "pipeline.dynamics.forces.limits" in [m.__name__ for m in element_modules()]
    from pathlib import Path

    import pipeline
    root = Path(pipeline.__file__).parent
    naming = sorted(p.relative_to(root).as_posix() for p in root.rglob("*.py")
                    if "JointLimit" in p.read_text() or "joint_limit" in p.read_text())
    assert naming == ["dynamics/forces/limits.py"], naming


class _Element:
    KIND = 40
    TYPE = "made_up"


def _module(*kernels, name="made_up"):
    return types.SimpleNamespace(__name__=name, KERNELS=kernels)


def _kernel(*args):
    return 0.0


@pytest.mark.parametrize("modules, match", [
    ((_module(Kernels((_Element,), _kernel, force=_kernel)),
      _module(Kernels((_Element,), _kernel, force=_kernel), name="again")), "kind 40 .* taken"),
    ((_module(Kernels((_Element,), None, force=_kernel)),), "needs a potential"),
    ((_module(Kernels((_Element,), _kernel)),), "either a push .* or a force"),
    ((_module(Kernels((_Element,), _kernel, push=_kernel, force=_kernel)),), "either a push"),
    ((_module(Kernels((type("Untyped", (), {"KIND": 41}),), _kernel, force=_kernel)),),
     "Untyped needs a TYPE of its own"),
    ((_module(("not", "kernels")),), r"made_up.KERNELS: expected Kernels"),
])
def test_a_broken_registration_is_refused_naming_its_module(modules, match):
    with pytest.raises(TypeError, match=match):
        _registry(modules)


def test_more_kinds_than_the_dispatchers_hold_are_refused():
    from pipeline.dynamics.forces.compiled import MAX_KINDS

    many = [type(f"K{i}", (), {"KIND": 100 + i, "TYPE": f"k{i}"}) for i in range(MAX_KINDS + 1)]
    _registry([_module(*[Kernels((c,), _kernel, force=_kernel) for c in many[:-1]])])
    with pytest.raises(TypeError, match=f"{MAX_KINDS + 1} element kinds registered"):
        _registry([_module(*[Kernels((c,), _kernel, force=_kernel) for c in many])])


ARM = """\
name: stopped_arm
gravity: [0, -9.81, 0]
links:
  ground:
    type: ground
    frames:
      O: {origin: [0, 0, 0]}
  arm:
    type: rigid
    mass: 2.0
    com: [0.5, 0, 0]
    inertia: [0.01, 0.2, 0.2, 0, 0, 0]
    frames:
      A: {origin: [0, 0, 0]}
joints:
  - {name: J1, type: revolute, parent: ground.O, child: arm.A, initial: [0.3]}
forces:
  - {name: stop, type: joint_limit, coordinate: J1.theta, lower: -0.5, stiffness: 1.0e4}
analyses:
  - {name: fall, type: dynamic, t_end: 0.45, outputs: 1801, rtol: 1.0e-9, atol: 1.0e-11}
"""


def test_a_workflow_offers_the_kind_and_names_a_bad_field(tmp_path):
    """An arm falls from 0.3 rad onto a stop at -0.5 rad: it goes in by x where the stop's
    k x^2 / 2 takes the weight's work m g r_c (sin 0.3 - sin(-0.5 - x)); a stop with its
    limits the wrong way round is refused at its line."""
    from scipy.optimize import brentq

    from pipeline.workflow import run_workflow

    path = tmp_path / "arm.yaml"
    path.write_text(ARM)
    res = run_workflow(path, out_root=tmp_path / "out", outputs=False)
    r = res.result("fall")
    assert res.manifest["status"] == "ok"
    x = brentq(lambda x: 0.5e4 * x * x - 2.0 * 9.81 * 0.5 * (np.sin(0.3) - np.sin(-0.5 - x)),
               1e-6, 0.5)
    assert r.q[:, 0].min() == pytest.approx(-0.5 - x, abs=2e-4 * x)
    path.write_text(ARM.replace("lower: -0.5", "lower: 0.5, upper: 0.4"))
    with pytest.raises(ConfigError, match=rf"{path}:18: .*forces\[0\].*lower: expected "
                                          r"below upper \(0.4\)"):
        run_workflow(path, out_root=tmp_path / "out2", outputs=False)
