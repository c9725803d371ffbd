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


def test_reference_blas_is_told_from_openblas():
    """Debian's alternatives: the netlib BLAS sits in blas/, OpenBLAS's libblas.so.3 in
    openblas-pthread/ (or openblas-openmp/); only the first is worth a warning."""
    lib = "/usr/lib/x86_64-linux-gnu"
    ref = f"{lib}/blas/libblas.so.3.11.0"
    assert eigen.reference_blas([f"{lib}/libcholmod.so.3.0.14", ref]) == ref
    assert eigen.reference_blas([f"{lib}/openblas-pthread/libblas.so.3",
                                 f"{lib}/openblas-pthread/libopenblas.so.0"]) is None
    assert eigen.reference_blas([f"{lib}/blas/libcblas.so.3"]) is None  # not the BLAS CHOLMOD calls
    assert eigen.reference_blas([]) is None


def test_reference_blas_warning_names_the_library(monkeypatch, caplog):
    """The check reads this process's mapped libraries once and warns only for the
    reference BLAS."""
    import builtins
    import io

    maps = ("7f00-7f01 r-xp 00000000 08:01 1 /usr/lib/x86_64-linux-gnu/blas/libblas.so.3\n"
            "7f02-7f03 r-xp 00000000 00:00 0 [vdso]\n")
    real_open = builtins.open
    monkeypatch.setattr(builtins, "open", lambda f, *a, **k: io.StringIO(maps)
                        if f == "/proc/self/maps" else real_open(f, *a, **k))
    monkeypatch.setattr(eigen.os.path, "realpath", lambda p: p)
    eigen._warn_reference_blas.cache_clear()
    try:
        with caplog.at_level("WARNING", logger="pipeline.modes.eigen"):
            eigen._warn_reference_blas()
        assert "reference BLAS (/usr/lib/x86_64-linux-gnu/blas/libblas.so.3)" in caplog.text
        assert "libopenblas0-pthread" in caplog.text
    finally:
        eigen._warn_reference_blas.cache_clear()


@needs_cholmod
@pytest.mark.gmsh
def test_a_reduction_on_cholmod_equals_the_one_on_superlu(tmp_path, monkeypatch):
    """A link reduced with CHOLMOD for every factor (as a large link is: the eigen solve
    and the stiffening load cases, solved in one block) equals the same link on SuperLU:
    frequencies, geometric stiffness, frame Hessians and stress modes."""
    from link_samples import solid_bar_spec

    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    spec = tmp_path / "bar.yaml"
    spec.write_text(solid_bar_spec("bar", 0.3, 0.01, 0.02, mesh_size=0.006, ends=("A", "tip"),
                                   modes="{count: 4, geometric_stiffening: true}"))
    solves, solve = {}, CholmodFactor.solve

    def counted(self, rhs):
        solves[current] = solves.get(current, []) + [np.shape(rhs)]
        return solve(self, rhs)

    monkeypatch.setattr(CholmodFactor, "solve", counted)
    links = {}
    for current, above in (("superlu", 10**9), ("cholmod", 0)):
        monkeypatch.setattr(eigen, "CHOLMOD_ABOVE", above)
        links[current] = reduce_spec(load_link_spec(spec), tmp_path, tmp_path / current)[0]
    assert "superlu" not in solves
    # the twelve inertia cases in one block, the two frames' six force cases in another
    assert {shape[1] for shape in solves["cholmod"] if len(shape) == 2} >= {12, 6}
    a, b = links["superlu"], links["cholmod"]
    np.testing.assert_allclose(b.frequencies_hz, a.frequencies_hz, rtol=1e-9)
    for field in ("inertia_geometric_stiffness", "force_geometric_stiffness"):
        A, B = getattr(a, field), getattr(b, field)
        np.testing.assert_allclose(B, A, rtol=0, atol=1e-6 * np.abs(A).max())
    np.testing.assert_allclose(b.stress_modes, a.stress_modes, rtol=0,
                               atol=1e-5 * np.abs(a.stress_modes).max())
