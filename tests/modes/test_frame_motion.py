"""Interface motions phi/psi against independent rigid fits and beam kinematics."""

import numpy as np
import pytest
from conftest import box_model, rigid_lstsq

from pipeline.core.errors import ConfigError
from pipeline.fem.interfaces import make_interface, tie_interfaces
from pipeline.modes import clamped_modes, frame_motion

L, B, H = 0.4, 0.02, 0.01


def _face(model, x):
    return np.flatnonzero(np.isclose(model.nodes[:, 0], x))


def _fit_all_modes(model, basis, nodes, origin):
    """(m, 6) independent lstsq rigid fits of every mode over ``nodes``."""
    u = basis.shapes[model.node_dofs[nodes]]  # (k, 3, m)
    return np.array([rigid_lstsq(model.nodes[nodes], origin, u[:, :, j])
                     for j in range(basis.n_modes)])


@pytest.mark.parametrize("tip_kind", ["rbe2", "rbe3"])
def test_phi_psi_equal_independent_rigid_fit(bar, tip_kind):
    origin = np.array([L + 0.03, 0.0, 0.02])  # off the face: rotations couple into phi
    root = make_interface(bar, "root", [0, B / 2, H / 2], None, "rbe2", _face(bar, 0))
    tip = make_interface(bar, "tip", origin, None, tip_kind, _face(bar, L))
    tied = tie_interfaces(bar, [root, tip])
    basis = clamped_modes(tied, "root", n_modes=6)
    phi, psi = frame_motion(bar, tied, basis, "tip")
    fit = _fit_all_modes(bar, basis, tip.nodes, origin)
    assert phi.shape == psi.shape == (6, 3)
    np.testing.assert_allclose(phi, fit[:, :3], rtol=0, atol=1e-9 * np.abs(phi).max())
    np.testing.assert_allclose(psi, fit[:, 3:], rtol=0, atol=1e-9 * np.abs(psi).max())
    # the clamped reference does not move
    phi0, psi0 = frame_motion(bar, tied, basis, root)
    assert np.abs(phi0).max() == 0.0 and np.abs(psi0).max() == 0.0


def test_marker_on_mid_span_nodes(bar):
    root = make_interface(bar, "root", [0, B / 2, H / 2], None, "rbe2", _face(bar, 0))
    tied = tie_interfaces(bar, [root])
    basis = clamped_modes(tied, "root", n_modes=4)
    mid = make_interface(bar, "mid", [L / 2, B / 2, H / 2], None, "rbe3", _face(bar, L / 2))
    phi, psi = frame_motion(bar, tied, basis, mid)
    fit = _fit_all_modes(bar, basis, mid.nodes, mid.origin)
    np.testing.assert_allclose(np.c_[phi, psi], fit, rtol=0, atol=1e-9 * np.abs(fit).max())
    # first mode bends in z (thin direction): mid-span moves along z and turns about y
    assert abs(phi[0, 2]) > 100 * abs(phi[0, 1]) and abs(psi[0, 1]) > 100 * abs(psi[0, 2])


def test_basis_of_another_model_is_rejected(bar):
    small = box_model(nx=4, ny=1, nz=1)
    root = make_interface(small, "root", [0, B / 2, H / 2], None, "rbe2", _face(small, 0))
    tied = tie_interfaces(small, [root])
    basis = clamped_modes(tied, "root", n_modes=2)
    with pytest.raises(ConfigError, match="does not belong to this model"):
        frame_motion(bar, tied, basis, "root")


def _beam(n_el=20, length=2.0, direction=(1.0, 0.0, 0.0)):
    from pipeline.fem.beam import assemble_beam
    from pipeline.fem.section import BeamSection
    from pipeline.meshing.mesh_data import MeshData

    e = np.asarray(direction, float) / np.linalg.norm(direction)
    pts = np.outer(np.linspace(0, length, n_el + 1), e)
    cells = np.c_[np.arange(n_el), np.arange(1, n_el + 1)]
    b, h = 0.04, 0.02
    sec = BeamSection(A=b * h, Iy=b * h ** 3 / 12, Iz=h * b ** 3 / 12, J=0.0125 * b * h ** 3 * 0.8,
                      E=210e9, G=81e9, rho=7850.0)
    mesh = MeshData(points=pts, cells={"line": cells}, kind="beam")
    return assemble_beam(mesh, sec, "boom"), sec


def test_beam_offset_interfaces():
    """Beam: the RBE2 reference with an offset origin clamps the node exactly; phi/psi at
    an offset origin are u_n + theta_n x d and theta_n read off the node (written here)."""
    pytest.importorskip("pipeline.fem.beam")
    model, sec = _beam()
    n_end = model.n_nodes - 1
    root = make_interface(model, "root", [-0.1, 0.05, 0.0], None, "rbe2", [0])
    tip_origin = model.nodes[n_end] + [0.2, 0.0, -0.1]
    tip = make_interface(model, "tip", tip_origin, None, "rbe3", [n_end])
    tied = tie_interfaces(model, [root, tip])
    basis = clamped_modes(tied, "root", n_modes=4)
    # clamped node 0: all its 6 DOFs are zero in every mode
    assert np.abs(basis.shapes[model.node_dofs[0]]).max() < 1e-14 * np.abs(basis.shapes).max()
    # Euler-Bernoulli cantilever, bending about y (Iy, thin) first; 20 Hermite elements
    f1 = 1.8751040687 ** 2 / (2 * np.pi * 2.0 ** 2) * np.sqrt(sec.E * sec.Iy / (sec.rho * sec.A))
    assert abs(basis.frequencies_hz[0] / f1 - 1) < 1e-3
    phi, psi = frame_motion(model, tied, basis, "tip")
    u = basis.shapes[model.node_dofs[n_end, :3]].T  # (m, 3)
    th = basis.shapes[model.node_dofs[n_end, 3:]].T
    d = tip_origin - model.nodes[n_end]
    np.testing.assert_allclose(psi, th, rtol=0, atol=1e-12 * np.abs(th).max())
    np.testing.assert_allclose(phi, u + np.cross(th, d), rtol=0, atol=1e-12 * np.abs(u).max())
    # an RBE2 at the same place reports the same motion (through its master DOFs)
    tip2 = make_interface(model, "tip", tip_origin, None, "rbe2", [n_end])
    tied2 = tie_interfaces(model, [root, tip2])
    basis2 = clamped_modes(tied2, "root", n_modes=4)
    phi2, psi2 = frame_motion(model, tied2, basis2, "tip")
    np.testing.assert_allclose(basis2.frequencies_hz, basis.frequencies_hz, rtol=1e-10)
    np.testing.assert_allclose(np.c_[phi2, psi2], np.c_[phi, psi], rtol=0,
                               atol=1e-9 * np.abs(phi).max())
