"""workflows/double_pendulum.yaml in --quick mode, checked against independent references.

Rigid case: an independent planar Lagrange derivation (sympy) of two rigid bodies whose
mass, centre of mass and inertia are read from the reduced links' C matrices (the
mesh's own mass moments), integrated with scipy. Flexible case: energy conservation.
Linearised rigid case: the closed-form characteristic equation of a compound double
pendulum.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from pipeline.workflow import run_workflow
from pipeline.workflow.series import series

ROOT = Path(__file__).resolve().parents[2]
WF = ROOT / "workflows" / "double_pendulum.yaml"
G = 9.81

pytestmark = pytest.mark.gmsh


@pytest.fixture(scope="module")
def run(quick_run):
    return quick_run("double_pendulum")


def _rigid_props(C):
    """mass, planar COM (2,), Izz about the COM from C = int rho r r^T dV."""
    m = C[3, 3]
    c = C[:3, 3] / m
    Izz_origin = C[0, 0] + C[1, 1]
    return m, c[:2], Izz_origin - m * (c[0] ** 2 + c[1] ** 2)


def _sympy_reference(p1, p2, L, y0, t):
    q1, q2, w1, w2 = sp.symbols("q1 q2 w1 w2")
    qs, ws = sp.Matrix([q1, q2]), sp.Matrix([w1, w2])

    def rot(a):
        return sp.Matrix([[sp.cos(a), -sp.sin(a)], [sp.sin(a), sp.cos(a)]])

    (m1, c1, I1), (m2, c2, I2) = p1, p2
    g1 = rot(q1) * sp.Matrix(c1)
    g2 = rot(q1) * sp.Matrix([L, 0]) + rot(q1 + q2) * sp.Matrix(c2)
    v1, v2 = g1.jacobian(qs) * ws, g2.jacobian(qs) * ws
    T = (m1 * v1.dot(v1) + I1 * w1 ** 2 + m2 * v2.dot(v2) + I2 * (w1 + w2) ** 2) / 2
    V = G * (m1 * g1[1] + m2 * g2[1])
    M = sp.hessian(T, ws)
    rhs = -(sp.Matrix([T]).jacobian(ws).jacobian(qs) * ws).T + sp.Matrix([T - V]).jacobian(qs)
    Mf, Ff = sp.lambdify([q1, q2, w1, w2], M), sp.lambdify([q1, q2, w1, w2], rhs.T)

    def f(_, y):
        acc = np.linalg.solve(np.asarray(Mf(*y), float), np.ravel(np.asarray(Ff(*y), float)))
        return np.concatenate([y[2:], acc])

    sol = solve_ivp(f, (t[0], t[-1]), y0, method="DOP853", t_eval=t, rtol=1e-12, atol=1e-12)
    assert sol.success
    return sol.y[:2].T


def test_rigid_case_matches_independent_lagrange(run):
    r = run.result("swing", "rigid")
    m = run.machines["rigid"]
    assert r.success, r.message
    props = [_rigid_props(np.asarray(m.parts[k].reduced.C)) for k in ("upper", "lower")]
    L = float(m.parts["upper"].reduced.frame("tip").pose[0, 3])
    ref = _sympy_reference(*props, L, np.zeros(4), r.t)
    err = np.abs(r.q - ref).max()
    assert err < 1e-7, err
    assert np.ptp(ref[:, 0]) > 0.2  # a real swing


def test_flexible_case_conserves_energy_and_bends(run):
    r = run.result("swing", "flexible")
    mech = run.machines["flexible"].mechanism
    assert r.success, r.message
    e = series(r, mech, "energy:total").values
    scale = np.abs(series(r, mech, "energy:kinetic").values).max()
    assert np.abs(e - e[0]).max() < 1e-7 * scale
    d = series(r, mech, "deflection:lower.tip:norm").values
    assert 1e-5 < d.max() < 0.05  # bends, elastically small
    assert r.extra["closure_residual"].max() < 1e-10


@pytest.mark.slow  # budget of the default run: .ci/run's slow run has it
def test_geometric_stiffening_keeps_the_energy_of_the_chaotic_swing(run, quick_run):
    """Both bars carry geometric stiffening (the shipped workflow): whipping at up to
    100 rad/s, their own spin and accelerations stiffen them through their second-order
    mass moments, which come with their kinetic energy: the balance closes as tightly as
    without (an approximate spin term pumped energy into the modes here and stopped the
    run; 3e-15 of the kinetic energy measured in quick mode). Without it the bending
    changes by 12 % of its peak, and the run says the model leaves that out."""
    r = run.result("swing", "flexible")
    mech = run.machines["flexible"].mechanism
    assert r.success and r.verdict == "ok", r.message
    e = series(r, mech, "energy:total").values
    scale = np.abs(series(r, mech, "energy:kinetic").values).max()
    assert np.abs(e - e[0]).max() < 1e-7 * scale
    d = series(r, mech, "deflection:lower.tip:norm").values
    # without stiffening, over 1 s: the lower bar whips past Omega^2 = 0.05 omega_1^2
    linear = quick_run("double_pendulum", ("links.upper.geometric_stiffening=false",
                                           "links.lower.geometric_stiffening=false",
                                           "analyses.swing.t_end=1.0"))
    r0 = linear.result("swing", "flexible")
    d0 = np.interp(r.t, r0.t, series(r0, linear.machines["flexible"].mechanism,
                                     "deflection:lower.tip:norm").values)
    assert np.abs(d - d0).max() > 0.05 * d0.max()  # 12 % of the peak measured
    assert r0.verdict == "suspect"
    assert any("link 'lower' spins at up to" in w and "geometric_stiffening: true" in w
               for w in r0.warnings), r0.warnings


def test_linearised_rigid_frequencies_match_closed_form(tmp_path_factory):
    out = tmp_path_factory.mktemp("dp_lin")
    res = run_workflow(WF, out_root=out, quick=True, outputs=False,
                       sets=["links.upper.modes=0", "links.lower.modes=0",
                             "analyses.swing.t_end=0.01", "analyses.swing.outputs=2"])
    r = res.result("modes")
    assert r.success, r.message
    m = res.machine
    (m1, c1, I1), (m2, c2, I2) = [_rigid_props(np.asarray(m.parts[k].reduced.C))
                                  for k in ("upper", "lower")]
    L = float(m.parts["upper"].reduced.frame("tip").pose[0, 3])
    # hanging straight down: linear M and K of the compound double pendulum
    a, b = np.hypot(*c1), np.hypot(*c2)
    M = np.array([[I1 + m1 * a ** 2 + m2 * L ** 2 + I2 + m2 * b ** 2 + 2 * m2 * L * c2[0],
                   I2 + m2 * b ** 2 + m2 * L * c2[0]],
                  [I2 + m2 * b ** 2 + m2 * L * c2[0], I2 + m2 * b ** 2]])
    K = G * np.array([[m1 * c1[0] + m2 * (L + c2[0]), m2 * c2[0]], [m2 * c2[0], m2 * c2[0]]])
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
    f_ref = np.sqrt(w2) / (2 * np.pi)
    assert np.allclose(r.extra["frequencies_hz"][:2], f_ref, rtol=1e-6), (
        r.extra["frequencies_hz"][:2], f_ref)


def test_deflection_in_its_own_link_axes_is_the_signed_modal_displacement(run):
    """deflection:lower.tip:y@lower equals the tip's modal displacement sum_a u_a eta_a in
    the body frame (from the reduced link's own mode shapes, no kinematics), signed; the
    ground-axes norm is its length."""
    from pipeline.core.errors import ConfigError

    r = run.result("swing", "flexible")
    m = run.machines["flexible"]
    mech = m.mechanism
    loc = series(r, mech, "deflection:lower.tip:y@lower").values
    part = m.parts["lower"]
    tip = part.reduced.frame("tip")
    eta = r.q[:, mech.modal_index[mech.link_index("lower")]]
    u_tip = eta @ np.asarray(tip.phi)[list(part.modes)]  # (T, 3) body-frame displacement
    # 1e-3: the kinematics place the frame by its pose S(eta), whose higher-order terms the
    # linear sum leaves out (here ~1e-4 of the deflection)
    tol = 1e-3 * np.abs(u_tip).max()
    np.testing.assert_allclose(loc, u_tip[:, 1], atol=tol)
    assert loc.min() < -100 * tol and loc.max() > 100 * tol  # signed, not a norm
    norm = series(r, mech, "deflection:lower.tip:norm").values
    np.testing.assert_allclose(norm, np.linalg.norm(u_tip, axis=1), atol=tol)
    with pytest.raises(ConfigError, match="axes 'nowhere'"):
        series(r, mech, "deflection:lower.tip:y@nowhere")


def test_the_total_energy_series_is_its_drift():
    """Issue 29: the energy panel plotted the total's level, a line at its start value whose
    drift no reader could see. The series is its change since the start, named so."""
    from types import SimpleNamespace

    from pipeline.workflow.series import series

    r = SimpleNamespace(name="swing", type="dynamic", t=np.arange(3.0),
                        energies={"total": np.array([5.0, 5.0 + 1e-9, 5.0 - 2e-9]),
                                  "kinetic": np.array([0.0, 1.0, 2.0])})
    s = series(r, None, "energy:total")
    np.testing.assert_allclose(s.values, [0.0, 1e-9, -2e-9], atol=1e-18)
    assert "change since the start" in s.label and s.unit == "J"
    np.testing.assert_array_equal(series(r, None, "energy:kinetic").values, [0.0, 1.0, 2.0])
