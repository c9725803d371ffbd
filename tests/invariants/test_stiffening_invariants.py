"""Geometric-stiffness invariants of a P2 solid bar and of the same bar as a Hermite beam
against Euler-Bernoulli integrals of the first in-plane bending mode phi_1 (clamped-free,
mass-normalised): the centrifugal K_G,11 = int rho A (L^2 - x^2) / 2 phi_1'^2 dx (spin
about z through the root); the tip's second-order axial translation d2x/deta_1^2 =
-int phi_1'^2 dx (the chord's shortening, from the unit tip-force case); the second-order
first moment of mass d2(int rho x dV)/deta_1^2 = -int rho A (L - x) phi_1'^2 dx (every
section pulled back by the shortening inboard of it, from the unit acceleration cases);
and the load cases' resultants."""

from __future__ import annotations

import numpy as np
import pytest
from link_samples import beam_spec, solid_bar_spec

from pipeline.fem.geometric import centrifugal_products, solid_centrifugal_loads
from pipeline.workflow.link_build import reduce_spec
from pipeline.workflow.link_spec import load_link_spec

pytestmark = pytest.mark.gmsh

L, B, H, E, RHO = 0.5, 0.01, 0.02, 2.1e11, 7850.0
ROOT = 1.8751040687


def _eb_first_mode():
    """Quadrature points, weights, phi_1' (mass-normalised) of the clamped-free bar."""
    xg, wg = np.polynomial.legendre.leggauss(200)
    x, w = 0.5 * L * (xg + 1), 0.5 * L * wg
    b = ROOT / L
    s = (np.cosh(b * L) + np.cos(b * L)) / (np.sinh(b * L) + np.sin(b * L))
    phi = np.cosh(b * x) - np.cos(b * x) - s * (np.sinh(b * x) - np.sin(b * x))
    dphi = b * (np.sinh(b * x) + np.sin(b * x) - s * (np.cosh(b * x) - np.cos(b * x)))
    return x, w, dphi / np.sqrt(RHO * B * H * (w @ phi ** 2))


def _eb_kg11() -> float:
    x, w, dphi = _eb_first_mode()
    return float(w @ (RHO * B * H * (L ** 2 - x ** 2) / 2 * dphi ** 2))


def _eb_shortening() -> float:
    _, w, dphi = _eb_first_mode()
    return float(w @ dphi ** 2)


def _eb_moving_mass() -> float:
    """int_0^L rho A int_0^x phi_1'^2 ds dx = int rho A (L - s) phi_1'^2 ds, kg m."""
    x, w, dphi = _eb_first_mode()
    return float(w @ (RHO * B * H * (L - x) * dphi ** 2))


def _reduce(folder, kind: str):
    modes = "{count: 4, geometric_stiffening: true}"
    spec = folder / "bar.yaml"
    if kind == "beam":
        spec.write_text(beam_spec("bar", L, A=B * H, Iy=B * H ** 3 / 12, Iz=H * B ** 3 / 12,
                                  J=1.0e-9, E=E, rho=RHO, element_size=0.02, ends=("A", "tip"),
                                  interfaces=("A", "tip"), z_axis=(0, 0, 1), modes=modes))
    else:
        spec.write_text(solid_bar_spec("bar", L, B, H, mesh_size=0.005, E=E, rho=RHO,
                                       ends=("A", "tip"), modes=modes))
    return reduce_spec(load_link_spec(spec), folder, folder / "links")[0]


@pytest.mark.parametrize("kind", ["solid", "beam"])
def test_centrifugal_stiffness_of_the_first_mode_is_euler_bernoulli(tmp_path, kind):
    link = _reduce(tmp_path, kind)
    tip = np.abs(link.mode_shapes[:, np.argmax(link.nodes[:, 0])])
    first_y = int(np.argmax(tip[:, 1] > 10 * tip[:, 2]))  # first mode bending along y
    KG = np.einsum("c,cab->ab", centrifugal_products([0.0, 0.0, 1.0]),
                   link.geometric_stiffness)
    assert KG[first_y, first_y] == pytest.approx(_eb_kg11(), rel=0.01)


@pytest.mark.parametrize("kind", ["solid", "beam"])
def test_tip_second_order_translation_is_the_chord_shortening(tmp_path, kind):
    """The unit tip-force case's geometric stiffness, read as the tip frame's second-order
    translation (ReducedLink.frame_hessians): bending in mode 1 pulls the tip back along the bar by
    int phi_1'^2 dx eta_1^2 / 2 (Euler-Bernoulli, within 1 %), and moves it not at all
    sideways at second order."""
    link = _reduce(tmp_path, kind)
    tip = np.abs(link.mode_shapes[:, np.argmax(link.nodes[:, 0])])
    a = int(np.argmax(tip[:, 1] > 10 * tip[:, 2]))
    H = link.frame_hessians()[[f.name for f in link.frames].index("tip")]
    assert H[a, a, 0] == pytest.approx(-_eb_shortening(), rel=0.01)
    assert np.abs(H[a, a, 1:]).max() < 1e-3 * abs(H[a, a, 0])


@pytest.mark.parametrize("kind", ["solid", "beam"])
def test_first_moment_moves_back_by_the_sections_shortening(tmp_path, kind):
    """The unit acceleration cases' geometric stiffness, read as the link's second-order
    first moment of mass (ReducedLink.second_order_moments, its mean): bending in mode 1
    moves every
    section back along the bar by the shortening inboard of it, so the first moment drops
    by int rho A (L - x) phi_1'^2 dx eta_1^2 / 2 (Euler-Bernoulli, within 1 %) and does not
    move sideways at second order."""
    link = _reduce(tmp_path, kind)
    tip = np.abs(link.mode_shapes[:, np.argmax(link.nodes[:, 0])])
    a = int(np.argmax(tip[:, 1] > 10 * tip[:, 2]))
    G = link.second_order_moments()
    H = G[:, :, 3]
    assert H[a, a, 0] == pytest.approx(-_eb_moving_mass(), rel=0.01)
    assert np.abs(H[a, a, 1:]).max() < 1e-3 * abs(H[a, a, 0])
    np.testing.assert_allclose(G, G.transpose(1, 0, 2, 3), atol=1e-12 * np.abs(G).max())
    # its first moment along the bar: every section's x times its pull-back,
    # int rho A x int_0^x phi'^2 = int rho A (L^2 - s^2) / 2 phi'^2 ds (the spin case's)
    assert G[a, a, 0, 0] == pytest.approx(-_eb_kg11(), rel=0.01)


def test_solid_centrifugal_load_resultant_is_m_w2_xc(tmp_path):
    """Spin w about z through the root: the load resultant is m w^2 x_c along x."""
    from skfem import MeshTet

    from pipeline.fem import Material, assemble_solid
    from pipeline.meshing.mesh_data import MeshData

    sk = MeshTet.init_tensor(np.linspace(0, L, 11), np.linspace(-B / 2, B / 2, 2),
                             np.linspace(-H / 2, H / 2, 3))
    model = assemble_solid(MeshData(sk.p.T, {"tetra": sk.t.T}, "solid"),
                           Material(E=E, nu=0.3, rho=RHO), "bar")
    f = np.einsum("c,cn->n", centrifugal_products([0.0, 0.0, 3.0]),
                  solid_centrifugal_loads(model, [0, 0, 0]))
    resultant = f[model.node_dofs].sum(axis=0)
    np.testing.assert_allclose(resultant, [RHO * B * H * L * 9.0 * L / 2, 0, 0], rtol=1e-10,
                               atol=1e-9)


def test_a_link_is_factorised_once(tmp_path, monkeypatch):
    """The eigen solve and the twelve geometric-stiffness load cases share one
    factorisation of the clamped stiffness (a 500 k DOF link's takes minutes; the load
    cases made two more)."""
    from pipeline.modes import clamp, eigen

    calls = []
    real = clamp.factorize

    def counting(*args, **kwargs):
        calls.append(args[0].shape)
        return real(*args, **kwargs)

    monkeypatch.setattr(clamp, "factorize", counting)
    monkeypatch.setattr(eigen, "factorize", counting)
    link = _reduce(tmp_path, "solid")
    assert link.force_geometric_stiffness.shape[0] == 2 and len(calls) == 1
