"""Craig-Bampton bases: orthonormality, exact statics, Rayleigh-Ritz convergence."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pipeline.core.errors import ConfigError
from pipeline.fem.interfaces import make_interface, tie_interfaces
from pipeline.modes import clamped_modes

L, B, H = 0.4, 0.02, 0.01
TIP = np.array([L + 0.05, B / 2, H / 2])  # master point offset beyond the end face


def _face(model, x):
    return np.flatnonzero(np.isclose(model.nodes[:, 0], x))


@pytest.fixture(scope="module")
def cantilever(bar):
    root = make_interface(bar, "root", [0, B / 2, H / 2], None, "rbe2", _face(bar, 0))
    tip = make_interface(bar, "tip", TIP, None, "rbe2", _face(bar, L))
    return bar, tie_interfaces(bar, [root, tip])


def _lagrange_tip_statics(model, load6):
    """Independent reference: Dirichlet clamp at x = 0, the tip face tied to a
    master point by Lagrange multipliers (u_i - t - theta x r_i = 0), unreduced.

    Returns the master motion [t; theta] under ``load6`` = [force; moment] at TIP.
    """
    root, tip = _face(model, 0), _face(model, L)
    free = np.setdiff1d(np.arange(model.n_dof), model.node_dofs[root].ravel())
    pos = {d: i for i, d in enumerate(free)}
    n, k = free.size, tip.size
    rows, cols, vals = [], [], []
    for j, node in enumerate(tip):
        r = model.nodes[node] - TIP
        skew_r = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        for a in range(3):
            eq = 3 * j + a
            rows += [eq]
            cols += [pos[model.node_dofs[node, a]]]
            vals += [1.0]
            # -(t + theta x r)_a = -t_a + (skew(r) theta)_a
            rows += [eq] + [eq] * 3
            cols += [n + a] + [n + 3 + b for b in range(3)]
            vals += [-1.0] + list(skew_r[a])
    K = sp.block_diag([model.stiffness[free][:, free], sp.csr_matrix((6, 6))])
    # constraint rows scaled like K: an unscaled saddle system loses ~5 digits in spsolve
    scale = np.abs(K.diagonal()).max()
    C = sp.csr_matrix((scale * np.array(vals), (rows, cols)), shape=(3 * k, n + 6))
    A = sp.bmat([[K, C.T], [C, None]]).tocsc()
    rhs = np.zeros(A.shape[0])
    rhs[n:n + 6] = load6
    sol = spla.spsolve(A, rhs)
    return sol[n:n + 6]


@pytest.mark.parametrize("n_modes", [0, 3])
def test_cb_statics_under_tip_force_and_moment_are_exact(cantilever, n_modes):
    model, tied = cantilever
    basis = clamped_modes(tied, "root", n_modes=n_modes, craig_bampton=True)
    Phi_m = basis.reduced_shapes[tied.master_dofs["tip"]]  # (6, m)
    for load in (np.array([0, 0, 1.0, 0, 0, 0]), np.array([0, 0, 0, 0, 1.0, 0]),
                 np.array([0.3, -1.0, 0.5, 0.2, -0.1, 1.0])):
        eta = np.linalg.solve(basis.modal_stiffness, Phi_m.T @ load)
        reduced = Phi_m @ eta
        full = _lagrange_tip_statics(model, load)
        err = np.abs(reduced - full).max() / np.abs(full).max()
        assert err < 1e-6, (load, err)


def test_cb_static_tip_deflection_is_near_euler_bernoulli(cantilever):
    """Sanity of the reference itself. A force P at the master point, offset a beyond the
    face, is P plus a moment P a at the face: w = P L^3/3EI + P a L^2/2EI,
    theta = P L^2/2EI + P a L/EI, and the master moves by w + theta a. Within 2 %
    (measured -1.1 %: the coarse P2 mesh is slightly stiff)."""
    model, _ = cantilever
    t_theta = _lagrange_tip_statics(model, np.array([0, 0, 1.0, 0, 0, 0]))
    EI, a = 210e9 * B * H ** 3 / 12, TIP[0] - L
    theta = L ** 2 / (2 * EI) + a * L / EI
    expected = L ** 3 / (3 * EI) + a * L ** 2 / (2 * EI) + theta * a
    assert abs(t_theta[2] / expected - 1) < 0.02
    assert abs(-t_theta[4] / theta - 1) < 0.02  # positive z-deflection = negative y-rotation


def test_cb_basis_is_orthonormal_and_labelled(cantilever):
    model, tied = cantilever
    basis = clamped_modes(tied, "root", n_modes=5, craig_bampton=True)
    Phi = basis.shapes
    w2 = basis.omega ** 2
    assert basis.n_modes == 11
    assert np.abs(Phi.T @ (model.mass @ Phi) - np.eye(11)).max() < 1e-8
    assert np.abs(Phi.T @ (model.stiffness @ Phi) - np.diag(w2)).max() < 1e-8 * w2.max()
    assert basis.kinds.count("constraint") == 6 and basis.kinds.count("normal") == 5
    assert basis.settings["cb_interfaces"] == ["tip"]


def test_cb_frequencies_converge_from_above(cantilever):
    """Rayleigh-Ritz on nested subspaces: monotone non-increasing, bounded below by the
    clamped model (root clamped, tip tied but free). Sequence printed with -s."""
    _, tied = cantilever
    exact = clamped_modes(tied, "root", n_modes=4).frequencies_hz
    seq = [clamped_modes(tied, "root", n_modes=n, craig_bampton=True).frequencies_hz[:4]
           for n in (0, 1, 2, 4, 8, 16)]
    seq = np.array(seq)
    print("\nCB lowest 4 frequencies (Hz) with 0,1,2,4,8,16 fixed-interface modes:\n", seq,
          "\nclamped model:", exact)
    assert np.all(seq >= exact * (1 - 1e-10))
    assert np.all(np.diff(seq, axis=0) <= 1e-9 * seq[1:])
    assert np.all(seq[-1] / exact - 1 < 2e-4)


def test_cb_needs_an_rbe2_interface(bar):
    root = make_interface(bar, "root", [0, B / 2, H / 2], None, "rbe2", _face(bar, 0))
    tip = make_interface(bar, "tip", TIP, None, "rbe3", _face(bar, L))
    tied = tie_interfaces(bar, [root, tip])
    with pytest.raises(ConfigError, match="needs at least one RBE2 interface besides"):
        clamped_modes(tied, "root", n_modes=2, craig_bampton=True)
    with pytest.raises(ConfigError, match="interface 'tip': Craig-Bampton constraint modes need "
                                          "kind 'rbe2', got 'rbe3'"):
        clamped_modes(tied, "root", n_modes=2, craig_bampton=True, interfaces=["tip"])


def test_cb_with_rbe3_reference(bar):
    """Averaged reference + rigid tip: still exact statics relative to the same clamp."""
    root = make_interface(bar, "root", [0, B / 2, H / 2], None, "rbe3", _face(bar, 0))
    tip = make_interface(bar, "tip", TIP, None, "rbe2", _face(bar, L))
    tied = tie_interfaces(bar, [root, tip])
    basis = clamped_modes(tied, "root", n_modes=4, craig_bampton=True)
    Phi = basis.shapes
    assert np.abs(Phi.T @ (bar.mass @ Phi) - np.eye(basis.n_modes)).max() < 1e-8
    assert np.abs(tied.rbe3_operators["root"] @ Phi).max() < 1e-12 * np.abs(Phi).max()
    exact = clamped_modes(tied, "root", n_modes=3).frequencies_hz
    assert np.all(basis.frequencies_hz[:3] >= exact * (1 - 1e-10))
