"""workflows/tractor_trailer.yaml in --quick mode against an independent sympy derivation.

The reference writes the same machine by hand: tractor pose from (x, y, z, yaw, pitch) with
roll held, trailer through the universal hitch (articulation yaw, trailer pitch), kinetic
energy of the two rigid bodies, potential of gravity and of the nine line springs (exact
lengths), Rayleigh dissipation of the dampers. sympy differentiates it; the equilibrium is
found with scipy. The workflow's static equilibrium and linearised M, C, K must agree.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import fsolve

from pipeline.workflow.load import load_workflow
from pipeline.workflow.series import series

WF = Path(__file__).resolve().parents[2] / "workflows" / "tractor_trailer.yaml"
# budget of the default run (11.5 min cold on a slow day): .ci/run's slow run has it
pytestmark = pytest.mark.slow
COORDS = ("TRACTOR.x", "TRACTOR.y", "TRACTOR.z", "TRACTOR.rz", "TRACTOR.ry", "HITCH.alpha",
          "HITCH.beta")


@pytest.fixture(scope="module")
def run(quick_run):
    return quick_run("tractor_trailer")


def _rot(axis, a):
    c, s = sp.cos(a), sp.sin(a)
    return {"x": sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]]),
            "y": sp.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
            "z": sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]


def _reference(spec):
    """Lambdified (grad V, Hessian V, M, C) in COORDS, from the workflow's numbers only."""
    q = sp.symbols("x y z psi theta alpha beta")
    x, y, z, psi, th, al, be = q
    links = spec.links
    tr, tl = links["tractor"], links["trailer"]
    c = sp.Matrix(links["ground"].frames["cg"].origin)
    R1 = _rot("z", psi) * _rot("y", th)
    h = sp.Matrix(tr.frames["hitch"].origin)
    F = sp.Matrix([[0, 0, 1], [0, -1, 0], [1, 0, 0]])  # hitch frame axes: x up, z forward
    R2 = R1 * F * _rot("x", al) * _rot("y", be) * F.T
    t = sp.Matrix([x, y, z])

    def p1(p):
        return c + t + R1 * (sp.Matrix(p) - c)

    def p2(p):
        return c + t + R1 * (h - c) + R2 * (sp.Matrix(p) - h)

    g = -spec.gravity[2]
    body_pt = {"tractor": p1, "trailer": p2}
    V = g * (tr.mass * p1(tr.com)[2] + tl.mass * p2(tl.com)[2])
    lengths, damp = [], []
    anchors = {**{k: f.origin for k, f in links["ground"].frames.items()},
               **{f"{n}.base": links[n].frames["base"].origin
                  for n in ("front_road", "drive_road", "trailer_road", "steer_road")}}
    zero = dict(zip(q, [0] * 7))
    for f in spec.forces:
        kw = f.model_extra
        a_link, a_frame = kw["marker_a"].split(".")
        b_link, b_frame = kw["marker_b"].split(".")
        a = sp.Matrix(anchors[a_frame] if a_link == "ground" else anchors[f"{a_link}.base"])
        b = body_pt[b_link](links[b_link].frames[b_frame].origin)
        ell = sp.sqrt(((b - a).T * (b - a))[0])
        ell0 = float(ell.subs(zero))
        V += kw["stiffness"] * (ell - ell0) ** 2 / 2
        lengths.append(ell)
        damp.append(kw["damping"])
    qv = sp.Matrix(q)
    grad = sp.Matrix([V]).jacobian(qv).T
    hess = grad.jacobian(qv)
    M = sp.zeros(7, 7)
    for body, R, pt in ((tr, R1, p1), (tl, R2, p2)):
        Jc = pt(body.com).jacobian(qv)
        I = np.array(body.inertia, dtype=float)
        Ib = sp.Matrix([[I[0], I[3], I[5]], [I[3], I[1], I[4]], [I[5], I[4], I[2]]])
        Jw = sp.zeros(3, 7)
        for i in range(7):
            W = R.diff(q[i]) * R.T
            Jw[:, i] = sp.Matrix([W[2, 1], W[0, 2], W[1, 0]])
        M += body.mass * Jc.T * Jc + Jw.T * (R * Ib * R.T) * Jw
    C = sp.zeros(7, 7)
    for ell, cd in zip(lengths, damp):
        d = sp.Matrix([ell]).jacobian(qv)
        C += cd * d.T * d
    f = [sp.lambdify([q], e, modules="numpy", cse=True) for e in (grad, hess, M, C)]
    return [lambda v, fn=fn: np.asarray(fn(v), dtype=float) for fn in f]


@pytest.fixture(scope="module")
def reference():
    spec = load_workflow(WF).spec
    grad, hess, M, C = _reference(spec)
    q_eq = fsolve(lambda v: grad(v).ravel(), np.zeros(7), xtol=1e-14)
    return q_eq, M(q_eq), C(q_eq), hess(q_eq)


def test_static_equilibrium_matches_reference(run, reference):
    q_eq = reference[0]
    r = run.result("rest")
    assert r.success, r.message
    q = r.q[0, [r.coordinates.index(c) for c in COORDS]]
    np.testing.assert_allclose(q, q_eq, atol=1e-9)
    assert -0.2 < q_eq[2] < -0.05  # the rig sinks ~0.1 m on its tyres and springs


def test_linearised_matrices_match_sympy(run, reference):
    _, M, C, K = reference
    r = run.result("modes")
    names = list(r.extra["x_coordinates"])
    order = [names.index(c) for c in COORDS]
    assert sorted(names) == sorted(COORDS)
    for ours, ref in ((r.extra["M"], M), (r.extra["K"], K), (r.extra["C"], C)):
        ours = np.asarray(ours)[np.ix_(order, order)]
        assert np.abs(ours - ref).max() <= 1e-8 * np.abs(ref).max(), np.abs(ours - ref).max()
    # natural frequencies |lambda| of the damped (non-proportional) first-order system
    A = np.block([[np.zeros((7, 7)), np.eye(7)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(A)
    wn = np.sort(np.abs(lam[lam.imag > 0]))
    np.testing.assert_allclose(np.sort(r.extra["omega"]), wn, rtol=1e-7)
    # ride and handling decouple about the straight, level equilibrium (seed's two models)
    ride, hand = [0, 2, 4, 6], [1, 3, 5]
    assert np.abs(K[np.ix_(ride, hand)]).max() < 1e-3 * np.abs(K).max()


def test_responses_settle_and_conserve_energy(run):
    for case in ("bump", "step steer"):
        r = run.result("response", case)
        mech = run.machines[case].mechanism
        assert r.success, r.message
        e = series(r, mech, "energy:total").values
        scale = np.abs(series(r, mech, "energy:dissipated").values).max()
        assert scale > 0 and np.abs(e - e[0]).max() < 1e-6 * max(scale, 1.0)
    bump = run.result("response", "bump")
    z = series(bump, run.machines["bump"].mechanism, "q:TRACTOR.z").values
    assert np.ptp(z) > 0.01  # the 50 mm bump moves the tractor
    steer = run.result("response", "step steer")
    yaw = series(steer, run.machines["step steer"].mechanism, "q:TRACTOR.rz").values
    assert np.abs(yaw).max() > 1e-4
