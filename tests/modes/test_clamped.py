"""Clamped (fixed-interface) normal modes against independent references."""

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from conftest import STEEL, box_model

from pipeline.core.errors import ConfigError, ModalError
from pipeline.fem.interfaces import make_interface, tie_interfaces
from pipeline.modes import clamped_modes

L, B, H = 0.4, 0.02, 0.01


def _face(model, x):
    return np.flatnonzero(np.isclose(model.nodes[:, 0], x))


def _tied(model, root_kind="rbe2", tip_kind=None):
    itfs = [make_interface(model, "root", [0, B / 2, H / 2], None, root_kind, _face(model, 0))]
    if tip_kind:
        itfs.append(make_interface(model, "tip", [L, B / 2, H / 2], None, tip_kind,
                                   _face(model, L)))
    return tie_interfaces(model, itfs)


def _check_orthonormal(model, basis, tol=1e-8):
    Phi = basis.shapes
    MM = Phi.T @ (model.mass @ Phi)
    KK = Phi.T @ (model.stiffness @ Phi)
    w2 = basis.omega ** 2
    assert np.abs(MM - np.eye(basis.n_modes)).max() < tol
    assert np.abs(KK - np.diag(w2)).max() < tol * w2.max()
    np.testing.assert_allclose(basis.modal_mass, MM, atol=1e-12)
    np.testing.assert_allclose(basis.modal_stiffness, KK, rtol=0, atol=1e-10 * w2.max())
    assert np.all(np.diff(basis.frequencies_hz) >= 0)


@pytest.mark.parametrize("root_kind", ["rbe2", "rbe3"])
def test_normal_modes_are_mass_normalised_and_k_diagonal(bar, root_kind):
    basis = clamped_modes(_tied(bar, root_kind, "rbe3"), "root", n_modes=8)
    _check_orthonormal(bar, basis)
    assert basis.kinds == ("normal",) * 8
    assert basis.settings["clamp_method"] == {"rbe2": "rbe2-masters", "rbe3": "rbe3-pivot"}[
        root_kind]


def test_rbe2_clamp_equals_dirichlet_clamp():
    """Reference: Dirichlet elimination of the face DOFs, solved with plain scipy eigsh.

    A stubby block (0.1 x 0.04 x 0.04 m): the agreement of two eigensolvers is
    limited by eps * lambda_max / lambda_1 (measured 1e-9 on the slender bar,
    whose ratio is 1.3e9; 1e-13 here, ratio 8.5e4).
    """
    model = box_model(0.1, 0.04, 0.04, 6, 3, 3)
    face = _face(model, 0)
    root = make_interface(model, "root", [0, 0.02, 0.02], None, "rbe2", face)
    basis = clamped_modes(tie_interfaces(model, [root]), "root", n_modes=6)
    free = np.setdiff1d(np.arange(model.n_dof), model.node_dofs[face].ravel())
    K, M = model.stiffness[free][:, free], model.mass[free][:, free]
    lam = spla.eigsh(K.tocsc(), k=6, M=M.tocsc(), sigma=0.0, which="LM",
                     return_eigenvectors=False)
    f_ref = np.sqrt(np.sort(lam)) / (2 * np.pi)
    rel = np.abs(basis.frequencies_hz / f_ref - 1)
    assert rel.max() < 1e-10, rel
    # and the clamped face does not move at all
    assert np.abs(basis.shapes[model.node_dofs[face].ravel()]).max() == 0.0


def test_solid_cantilever_first_bending_matches_euler_bernoulli():
    """0.4 x 0.02 x 0.01 m steel bar (L/h = 40), 32 x 2 x 2 hexes in P2 tets (4875 DOFs).

    Measured: +0.41 % (thin direction) and +0.15 % (wide direction) vs EB.
    """
    model = box_model(nx=32)
    basis = clamped_modes(_tied(model), "root", n_modes=2)
    coef = 1.8751040687 ** 2 / (2 * np.pi * L ** 2) * np.sqrt(STEEL["E"] / (STEEL["rho"] * B * H))
    f_eb = coef * np.sqrt([B * H ** 3 / 12, H * B ** 3 / 12])
    rel = basis.frequencies_hz / f_eb - 1
    assert np.all(np.abs(rel) < 5e-3), rel


def test_rbe3_clamp_is_an_exact_constraint():
    """Reference: dense null space of G T (scipy.linalg.null_space, an SVD) instead of pivoting."""
    bar = box_model(nx=6, ny=2, nz=1)
    tied = _tied(bar, "rbe3")
    basis = clamped_modes(tied, "root", n_modes=5)
    G = tied.rbe3_operators["root"]
    assert np.abs(G @ basis.shapes).max() < 1e-12 * np.abs(basis.shapes).max()
    N = la.null_space((G @ tied.transform).toarray())
    K = N.T @ tied.stiffness.toarray() @ N
    M = N.T @ tied.mass.toarray() @ N
    lam = la.eigh(K, M, subset_by_index=[0, 4], eigvals_only=True)
    rel = np.abs(basis.frequencies_hz / (np.sqrt(lam) / (2 * np.pi)) - 1)
    assert rel.max() < 1e-7, rel  # dense reference limited by its own conditioning
    # averaging support is softer than a rigid clamp of the same face
    rigid = clamped_modes(_tied(bar, "rbe2"), "root", n_modes=5)
    assert np.all(basis.frequencies_hz < rigid.frequencies_hz)


def test_selection_by_frequency_cutoff(bar):
    tied = _tied(bar)
    every = clamped_modes(tied, "root", n_modes=30)
    f_max = 0.5 * (every.frequencies_hz[13] + every.frequencies_hz[14])
    cut = clamped_modes(tied, "root", f_max=f_max)
    assert cut.n_modes == 14
    np.testing.assert_allclose(cut.frequencies_hz, every.frequencies_hz[:14], rtol=1e-10)
    both = clamped_modes(tied, "root", n_modes=5, f_max=f_max)
    assert both.n_modes == 5
    with pytest.raises(ModalError, match=r"link 'bar': f_max = 1.0 Hz selects no mode; the "
                                         r"first one is at 52.6"):
        clamped_modes(tied, "root", f_max=1.0)


def test_signs_are_deterministic_and_follow_the_convention(bar):
    tied = _tied(bar, "rbe2", "rbe2")
    a = clamped_modes(tied, "root", n_modes=6)
    b = clamped_modes(tied, "root", n_modes=6)
    np.testing.assert_array_equal(a.shapes, b.shapes)
    idx = np.argmax(np.abs(a.shapes), axis=0)
    assert np.all(a.shapes[idx, np.arange(6)] > 0)
    # a different start (other ordering) converges to the same signed vectors
    c = clamped_modes(tied, "root", n_modes=6, ordering="COLAMD")
    np.testing.assert_allclose(c.shapes, a.shapes, atol=1e-7 * np.abs(a.shapes).max())


def test_too_many_modes_and_bad_requests():
    model = box_model(nx=2, ny=1, nz=1)
    tied = _tied(model)
    n_c = tied.n_red - 6
    assert clamped_modes(tied, "root", n_modes=n_c).n_modes == n_c  # all of them (dense)
    with pytest.raises(ModalError, match=f"asked for {n_c + 1} modes but the clamped model has "
                                         f"only {n_c} DOFs"):
        clamped_modes(tied, "root", n_modes=n_c + 1)
    with pytest.raises(ConfigError, match="give n_modes or f_max"):
        clamped_modes(tied, "root")
    with pytest.raises(ConfigError, match=r"no interface 'hub'; available: \['root'\]"):
        clamped_modes(tied, "hub", n_modes=2)
    for n_modes in (0, -1, 2.5):  # 0 is for Craig-Bampton (constraint modes alone) only
        with pytest.raises(ConfigError, match=f"n_modes: expected an integer >= 1, got "
                                              f"{n_modes}"):
            clamped_modes(tied, "root", n_modes=n_modes)


@pytest.mark.parametrize("stored_zeros", [False, True])
def test_unclamped_part_is_reported(stored_zeros):
    """Two disjoint bars in one model: clamping the first leaves the second free. Stored
    zeros between them (a sparse pattern wider than the coupling) join nothing."""
    m = box_model(nx=4, ny=1, nz=1)
    n = m.n_dof
    Z = sp.csr_matrix((np.zeros(n), (np.arange(n), np.arange(n))), shape=(n, n)) \
        if stored_zeros else None
    K = sp.bmat([[m.stiffness, Z], [Z, m.stiffness]], format="csr")
    assert K.nnz == 2 * m.stiffness.nnz + (2 * n if stored_zeros else 0)
    two = type(m)("two", "solid", np.vstack([m.nodes, m.nodes + [1.0, 0, 0]]),
                  np.vstack([m.node_dofs, m.node_dofs + m.n_dof]), K,
                  sp.block_diag([m.mass, m.mass]).tocsr())
    # an RBE3 reference keeps K as it is (an RBE2 tie's products drop the stored zeros)
    kind = "rbe3" if stored_zeros else "rbe2"
    root = make_interface(two, "root", [0, 0, 0], None, kind, _face(two, 0))
    with pytest.raises(ModalError, match=r"link 'two': clamped at 'root', 1 part\(s\) of the "
                                         r"model \(\d+ of \d+ DOFs\) are not connected"):
        clamped_modes(tie_interfaces(two, [root]), "root", n_modes=8)


def test_a_fine_beam_mesh_is_reduced_with_a_warning_not_refused():
    """A 24 m boom at 5 mm elements: its first mode (omega^2 14.8, 0.61 Hz; 14.84 at 0.5 m
    elements) is 4e-17 of the mesh's largest eigenvalue, which an eigenvalue threshold took
    for a rigid mode and refused. It is connected and clamped, so it is reduced; the
    threshold only warns."""
    from pipeline.fem.beam import assemble_beam
    from pipeline.fem.section import BeamSection
    from pipeline.meshing.mesh_data import MeshData

    n_el = 4800
    pts = np.outer(np.linspace(0.0, 24.0, n_el + 1), [1.0, 0, 0])
    cells = np.c_[np.arange(n_el), np.arange(1, n_el + 1)]
    sec = BeamSection(A=1.2e-2, Iy=6.667e-5, Iz=1.333e-4, J=1.333e-4, E=2.1e11, G=8.1e10,
                      rho=7850.0)
    model = assemble_beam(MeshData(points=pts, cells={"line": cells}, kind="beam"), sec, "boom")
    root = make_interface(model, "root", [0, 0, 0], None, "rbe2", np.array([0]))
    basis = clamped_modes(tie_interfaces(model, [root]), "root", n_modes=2)
    EI, m = 2.1e11 * 6.667e-5, 7850 * 1.2e-2  # cantilever: (1.8751 / L)^4 EI / m
    assert basis.frequencies_hz[0] == pytest.approx(
        1.8751 ** 2 / (2 * np.pi * 24.0 ** 2) * np.sqrt(EI / m), rel=1e-3)
    assert "round-off" in basis.settings["warnings"][0]


@pytest.mark.parametrize("root_kind, chord", [("rbe2", None), ("rbe3", None), ("rbe2", "tip")])
def test_projection_is_l_transpose_a_l(root_kind, chord):
    """The clamped space's projection (a selection plus low-rank terms) equals L^T A L
    formed densely, for a clamp by masters, by pivoting (RBE3) and by the chord; A is
    unsymmetric so that no term can stand in for its transpose."""
    from pipeline.modes.clamp import reference_space

    tied = _tied(box_model(nx=3, ny=1, nz=1), root_kind, "rbe2")
    space = reference_space(tied, "root", chord)
    rng = np.random.default_rng(5)
    A = sp.random(tied.n_red, tied.n_red, density=0.2, random_state=rng, format="csr")
    A = A + sp.identity(tied.n_red)
    expected = space.L.T.toarray() @ A.toarray() @ space.L.toarray()
    assert space.method == {("rbe2", None): "rbe2-masters", ("rbe3", None): "rbe3-pivot",
                            ("rbe2", "tip"): "chord"}[(root_kind, chord)]
    np.testing.assert_allclose(space.project(A).toarray(), expected, rtol=1e-12, atol=1e-12)
