"""The sparse factorisations behind the eigen solves: SuperLU (always) and CHOLMOD
(scikit-sparse, optional, used for large links) give the same solves and modes."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.core.errors import ConfigError, ModalError
from pipeline.modes import eigen
from pipeline.modes.eigen import CholmodFactor, factorize, lowest_modes


@pytest.fixture(scope="module")
def clamped(bar):
    """The skfem P2 bar clamped at x = 0 (Dirichlet): K, M (SPD)."""
    root = np.flatnonzero(np.isclose(bar.nodes[:, 0], 0.0))
    free = np.setdiff1d(np.arange(bar.n_dof), bar.node_dofs[root].ravel())
    return bar.stiffness[free][:, free].tocsc(), bar.mass[free][:, free].tocsc()


needs_cholmod = pytest.mark.skipif(eigen._cholmod() is None,
                                   reason="scikit-sparse (CHOLMOD) not installed")


@needs_cholmod
def test_cholmod_and_superlu_solve_alike(clamped):
    K, M = clamped
    b = np.random.default_rng(1).standard_normal((K.shape[0], 3))
    x_lu = factorize(K, backend="superlu").solve(b)
    x_ch = factorize(K, backend="cholmod").solve(b)
    # the slender bar's K has cond ~1e8: the two agree to round-off times that
    assert np.abs(x_ch - x_lu).max() < 1e-7 * np.abs(x_lu).max()
    assert np.abs(K @ x_ch - b).max() < 1e-8 * np.abs(b).max()
    lam_lu, _ = lowest_modes(K, M, 6, lu=factorize(K, backend="superlu"))
    lam_ch, _ = lowest_modes(K, M, 6, lu=factorize(K, backend="cholmod"))
    np.testing.assert_allclose(lam_ch, lam_lu, rtol=1e-8)


@needs_cholmod
def test_auto_takes_cholmod_for_large_matrices(clamped, monkeypatch):
    K, _ = clamped
    assert not isinstance(factorize(K), CholmodFactor)  # ~2 k DOF: SuperLU
    monkeypatch.setattr(eigen, "CHOLMOD_ABOVE", 100)
    assert isinstance(factorize(K), CholmodFactor)
    with pytest.raises(ModalError, match="not positive definite"):
        factorize(-K, backend="cholmod")


def test_backend_errors(clamped, monkeypatch):
    K, _ = clamped
    with pytest.raises(ConfigError, match="backend: expected auto, superlu or cholmod"):
        factorize(K, backend="mumps")
    monkeypatch.setattr(eigen, "_cholmod", lambda: None)
    with pytest.raises(ConfigError, match="needs scikit-sparse"):
        factorize(K, backend="cholmod")
    monkeypatch.setattr(eigen, "CHOLMOD_ABOVE", 100)
    assert not isinstance(factorize(K), CholmodFactor)  # auto falls back to SuperLU
