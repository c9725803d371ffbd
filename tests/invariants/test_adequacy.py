"""Static coverage of a reduction basis (pipeline.invariants.adequacy) against independent
references: the stored full-model compliance against Euler-Bernoulli closed forms, the
constrained Ritz compliance against a Lagrange-multiplier solve, round-off rows that must
not hold a mode, and the Craig-Bampton block solve against a direct sparse solve."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from link_samples import boom_spec

from pipeline.invariants.adequacy import (
    HOLD_RTOL,
    attachment_basis,
    coverage_report,
    ritz_compliance,
    static_coverage,
    stored_compliance,
)

L, A_PIN, E, A, IZ, IY = 2.0, 0.8, 2.1e11, 1.0e-3, 1.0e-6, 4.0e-6


def _spec(modes: str) -> str:
    return boom_spec(L, A_PIN, A=A, Iy=IY, Iz=IZ, J=4.0e-6, E=E, modes=modes, element_size=0.1)


@pytest.fixture(scope="module")
def boom(tmp_path_factory):
    """The same cantilever reduced with 4 clamped modes and with Craig-Bampton."""
    from pipeline.api import reduce_link

    folder = tmp_path_factory.mktemp("boom")
    out = {}
    for key, modes in (("clamped", "{count: 4}"), ("cb", "{count: 4, craig_bampton: true}")):
        (folder / f"{key}.yaml").write_text(_spec(modes))
        out[key] = reduce_link(folder / f"{key}.yaml", folder / "links")
    return out


def test_stored_compliance_is_the_cantilever_s_closed_form(boom):
    """Hermite beams are exact for end loads: the stored C is the cantilever flexibility
    (x1^2 (3 x2 - x1) / 6 EI between two stations, L / EA axially, x / EI in rotation)."""
    names, C = stored_compliance(boom["clamped"])
    assert names == ("pin", "tip")
    y = lambda i: 6 * names.index(i) + 1
    flex = lambda x1, x2: x1 ** 2 * (3 * x2 - x1) / (6 * E * IZ)
    np.testing.assert_allclose(C[y("tip"), y("tip")], flex(L, L), rtol=1e-9)
    np.testing.assert_allclose(C[y("pin"), y("pin")], flex(A_PIN, A_PIN), rtol=1e-9)
    np.testing.assert_allclose(C[y("pin"), y("tip")], flex(A_PIN, L), rtol=1e-9)
    np.testing.assert_allclose(C[6 + 0, 6 + 0], L / (E * A), rtol=1e-9)  # tip axial
    np.testing.assert_allclose(C[6 + 5, 6 + 5], L / (E * IZ), rtol=1e-9)  # tip rotation z
    np.testing.assert_allclose(C[6 + 1, 6 + 5], L ** 2 / (2 * E * IZ), rtol=1e-9)
    np.testing.assert_allclose(C, C.T, atol=1e-12 * np.abs(C).max())
    # the Craig-Bampton reduction solves its statics on the factor of K_ii: the same C
    np.testing.assert_allclose(stored_compliance(boom["cb"])[1], C, rtol=1e-8,
                               atol=1e-10 * np.abs(C).max())


def test_coverage_is_a_rayleigh_ritz_share(boom):
    """Kept modes carry at most the full compliance; Craig-Bampton carries all of it at its
    interfaces; the lowest clamped mode alone carries 97 % of a cantilever's tip deflection
    (the first mode's share, 0.9707 for a uniform Euler-Bernoulli cantilever)."""
    for link in boom.values():
        for c in static_coverage(link):
            assert c.kept <= c.full * (1 + 1e-9) + 1e-30
    for c in static_coverage(boom["cb"]):
        assert c.ratio == pytest.approx(1.0, abs=1e-8), c
    first = [c for c in static_coverage(boom["clamped"], modes=[0]) if c.frame == "tip"]
    y_or_z = max(first, key=lambda c: c.ratio)
    assert y_or_z.ratio == pytest.approx(0.9707, abs=2e-3)


def test_the_axial_direction_a_bending_basis_misses_is_named(boom):
    """Four bending modes carry none of the tip's axial compliance: relevant only if it is
    a fair share of the softest direction (here L/EA is 4e-4 of L^3/3EI: not reported)."""
    rep = coverage_report(boom["clamped"])
    axial = next(r for r in rep["rows"] if r["frame"] == "tip" and r["direction"] == "x")
    assert axial["share"] < 1e-6 and not axial["relevant"]
    assert rep["warnings"] == []


def test_ritz_compliance_with_held_rows_equals_a_lagrange_multiplier_solve():
    rng = np.random.default_rng(3)
    m, F = 7, 3
    X = rng.normal(size=(m, m))
    K = X @ X.T + m * np.eye(m)
    G = rng.normal(size=(6 * F, m))
    held = rng.normal(size=(2, 6 * F))
    w = rng.normal(size=6 * F)
    # max (w G a)^2 / a^T K a subject to held G a = 0: the stationarity system
    Hg = held @ G
    kkt = np.block([[K, Hg.T], [Hg, np.zeros((2, 2))]])
    a = np.linalg.solve(kkt, np.concatenate([G.T @ w, np.zeros(2)]))[:m]
    assert ritz_compliance(G, K, w, held) == pytest.approx(float(w @ G @ a), rel=1e-10)
    # unheld: w G K^-1 G^T w
    assert ritz_compliance(G, K, w, np.zeros((0, 6 * F))) == pytest.approx(
        float(w @ G @ np.linalg.solve(K, G.T @ w)), rel=1e-12)


def test_a_row_that_acts_only_through_round_off_holds_nothing():
    """A mesh that is not quite symmetric gives an in-plane mode a 1e-13 out-of-plane
    motion at a lug: a joint row there must not lock the mode (issue 24: the only kept
    mode was held at zero, status ok). A row that really acts does hold it."""
    K = np.diag([4.0, 9.0])
    G = np.zeros((6, 2))
    G[1] = [1.0, 0.3]  # in-plane motion of the frame
    G[2] = [1e-13, 0.0]  # round-off out of the plane
    w = np.eye(6)[1]
    free = ritz_compliance(G, K, w, np.zeros((0, 6)))
    assert ritz_compliance(G, K, w, np.eye(6)[[2]]) == pytest.approx(free, rel=1e-12)
    assert ritz_compliance(G, K, w, np.eye(6)[[1]]) < 1e-20 * free
    # just above the tolerance, the same row holds the mode it moves
    G[2] = [10 * HOLD_RTOL, 0.0]
    assert ritz_compliance(G, K, w, np.eye(6)[[2]]) < 0.9 * free


def test_the_attachment_basis_reproduces_the_compliance():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(12, 5))
    C = X @ X.T  # rank 5: directions the reference holds have none
    Ga, Ka = attachment_basis(C)
    assert Ga.shape == (12, 5)
    np.testing.assert_allclose(Ga @ np.linalg.solve(Ka, Ga.T), C, atol=1e-12 * np.abs(C).max())


def test_the_craig_bampton_block_solve_equals_a_direct_solve():
    from pipeline.modes.craig_bampton import BlockSolve
    from pipeline.modes.eigen import factorize

    n = 60
    rng = np.random.default_rng(1)
    R = sp.random(n, n, density=0.1, random_state=2)
    K = (R @ R.T + n * sp.eye(n)).tocsr()
    boundary = np.array([3, 17, 40, 41])
    interior = np.setdiff1d(np.arange(n), boundary)
    lu = factorize(K[interior][:, interior].tocsc())
    Psi = -lu.solve(K[interior][:, boundary].toarray())
    b = rng.normal(size=(n, 3))
    np.testing.assert_allclose(BlockSolve(K, boundary, lu, Psi).solve(b),
                               spla.spsolve(K.tocsc(), b), rtol=1e-10, atol=1e-12)


def _first_mode_weight_share() -> tuple[float, float]:
    """(full, first mode's) work of a uniform cantilever's own weight, per (rho A)^2 L^5 / EI:
    1/20 from the static deflection q x^2 (6 L^2 - 4 L x + x^2) / 24 EI, and
    (int phi)^2 / (beta^4 int phi^2) from the analytic first mode (quadrature)."""
    from scipy.integrate import quad

    b = 1.8751040687  # beta L
    sig = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))

    def phi(x):
        return np.cosh(b * x) - np.cos(b * x) - sig * (np.sinh(b * x) - np.sin(b * x))

    i1 = quad(phi, 0, 1, epsabs=1e-14)[0]
    i2 = quad(lambda x: phi(x) ** 2, 0, 1, epsabs=1e-14)[0]
    return 1.0 / 20.0, i1 ** 2 / (b ** 4 * i2)


def test_own_weight_coverage_is_the_cantilever_s_closed_form(boom):
    """The stored work of a unit acceleration across the boom (its own weight) is the
    cantilever's (rho A)^2 L^5 / 20 EI; its first clamped mode carries the closed-form
    share of it (0.9918, from the analytic mode shape); Craig-Bampton with four normal
    modes carries 99 % of the bending directions (not all: its static modes are the
    interfaces', and the axial weight, 93 %, is too stiff to count); and the report names
    the row."""
    from pipeline.invariants.adequacy import (
        BODY_LOAD,
        body_load_coverage,
        body_relevance,
        softest,
    )

    rho = 7850.0
    full, first = _first_mode_weight_share()
    rows = {c.direction: c for c in body_load_coverage(boom["clamped"], modes=[0])}
    scale = (rho * A) ** 2 * L ** 5 / (E * IZ)
    soft = max(rows.values(), key=lambda c: c.full)  # bending about the softer axis
    assert soft.full == pytest.approx(full * scale, rel=1e-6)
    assert soft.ratio == pytest.approx(first / full, abs=2e-3)
    assert 0.99 < first / full < 0.995
    cb = body_relevance(body_load_coverage(boom["cb"]), boom["cb"].mass,
                        softest(static_coverage(boom["cb"])))
    assert {c.direction for c in cb if c.relevant} == {"y", "z"}
    for c in cb:
        assert c.frame == BODY_LOAD and (c.ratio > 0.99 or not c.relevant)
    report = coverage_report(boom["clamped"], modes=[0])
    assert any(r["frame"] == BODY_LOAD for r in report["rows"])
