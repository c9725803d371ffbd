"""Vectorised P2 tetrahedron kernels: linear-elasticity stiffness and mass.

Every element integral is written as one dense matrix product over a batch of
elements, so numpy/BLAS does the work instead of a Python loop:

* gradient integrals ``D[(a, b), e, (i, j)] = int dN_i/dx_a dN_j/dx_b dV``
  are ``W[(a, b), e, (q, k, l)] @ G[(q, k, l), (i, j)]`` with
  ``W = w_q |det J_q| invJ_q[k, a] invJ_q[l, b]`` (geometry) and
  ``G = dN_i/dxi_k dN_j/dxi_l`` at the reference quadrature points. For
  affine elements J is constant, so the quadrature sum is precomputed once
  (``A[(k, l), (i, j)]``) and the product shrinks to 9 x 9 per element.
* scalar mass ``m[e, (i, j)] = int N_i N_j dV`` is ``w_q |det J_q|`` times the
  table ``N_i N_j`` (one (e, q) @ (q, 100) product).

The elasticity stiffness follows from D without another element pass:
``K[(i, a), (j, b)] = lam D_ab + mu D_ba + mu delta_ab tr(D)``, so only the 9
components of D are scattered into the (node, node) sparsity pattern, once.
Local node order is skfem's ``ElementTetP2``: 4 vertices, then the midpoints
of edges (0,1), (1,2), (0,2), (0,3), (1,3), (2,3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

EDGES = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))
_GRAD_L = np.array([[-1.0, -1.0, -1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
# Elements per batch: bounds the per-batch arrays (geometry factors and the
# 900 gradient integrals per element) to ~128 MB.
_BATCH_DOUBLES = 16_000_000


def p2_shape(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """P2 shape functions on the reference tetrahedron.

    Parameters
    ----------
    xi : (3, q) array
        Reference coordinates.

    Returns
    -------
    N : (q, 10) array
        Shape-function values.
    dN : (q, 10, 3) array
        Derivatives dN_i/dxi_k.

    Examples
    --------
    >>> N, dN = p2_shape(np.array([[0.25], [0.25], [0.25]]))
    >>> float(N.sum()), float(np.abs(dN.sum(axis=1)).max())
    (1.0, 0.0)
    """
    x, y, z = np.asarray(xi, float)
    L = np.stack([1.0 - x - y - z, x, y, z], axis=1)  # (q, 4) barycentrics
    N = np.empty((L.shape[0], 10))
    dN = np.empty((L.shape[0], 10, 3))
    for v in range(4):
        N[:, v] = L[:, v] * (2.0 * L[:, v] - 1.0)
        dN[:, v] = (4.0 * L[:, v] - 1.0)[:, None] * _GRAD_L[v]
    for k, (i, j) in enumerate(EDGES):
        N[:, 4 + k] = 4.0 * L[:, i] * L[:, j]
        dN[:, 4 + k] = 4.0 * (L[:, j, None] * _GRAD_L[i] + L[:, i, None] * _GRAD_L[j])
    return N, dN


@dataclass(frozen=True)
class ReferenceRule:
    """Quadrature tables on the reference tetrahedron for one order."""

    N: np.ndarray  # (q, 10)
    dN: np.ndarray  # (q, 10, 3)
    weights: np.ndarray  # (q,)
    NN: np.ndarray  # (q, 100): N_i N_j
    GG: np.ndarray  # (q, 9, 100): dN_i/dxi_k dN_j/dxi_l, (k, l) x (i, j)

    @classmethod
    def of_order(cls, intorder: int) -> ReferenceRule:
        """Tables for skfem's tetrahedron rule exact to degree ``intorder``."""
        from skfem.quadrature import get_quadrature
        from skfem.refdom import RefTet

        xi, w = get_quadrature(RefTet, intorder)
        N, dN = p2_shape(xi)
        NN = np.einsum("qi,qj->qij", N, N).reshape(-1, 100)
        GG = np.einsum("qik,qjl->qklij", dN, dN).reshape(-1, 9, 100)
        return cls(N, dN, np.asarray(w, float), NN, GG)


def jacobians(X: np.ndarray, rule: ReferenceRule | None) -> np.ndarray:
    """Jacobians dx/dxi of P2 (or affine) elements.

    Parameters
    ----------
    X : (e, 10, 3) array
        Node coordinates per element, m, in local node order.
    rule : ReferenceRule or None
        ``None``: affine elements, J from the vertices only.

    Returns
    -------
    (e, 3, 3) array for affine elements, (e, q, 3, 3) otherwise; J[..., i, k].
    """
    if rule is None:
        return (X[:, 1:4, :] - X[:, :1, :]).transpose(0, 2, 1)
    return np.einsum("eni,qnk->eqik", X, rule.dN, optimize=True)


def inverse_and_det(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched inverse and determinant of 3 x 3 matrices by cofactors."""
    cof = np.empty_like(J)
    cof[..., 0, 0] = J[..., 1, 1] * J[..., 2, 2] - J[..., 1, 2] * J[..., 2, 1]
    cof[..., 0, 1] = J[..., 1, 2] * J[..., 2, 0] - J[..., 1, 0] * J[..., 2, 2]
    cof[..., 0, 2] = J[..., 1, 0] * J[..., 2, 1] - J[..., 1, 1] * J[..., 2, 0]
    cof[..., 1, 0] = J[..., 0, 2] * J[..., 2, 1] - J[..., 0, 1] * J[..., 2, 2]
    cof[..., 1, 1] = J[..., 0, 0] * J[..., 2, 2] - J[..., 0, 2] * J[..., 2, 0]
    cof[..., 1, 2] = J[..., 0, 1] * J[..., 2, 0] - J[..., 0, 0] * J[..., 2, 1]
    cof[..., 2, 0] = J[..., 0, 1] * J[..., 1, 2] - J[..., 0, 2] * J[..., 1, 1]
    cof[..., 2, 1] = J[..., 0, 2] * J[..., 1, 0] - J[..., 0, 0] * J[..., 1, 2]
    cof[..., 2, 2] = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    det = np.einsum("...k,...k->...", J[..., 0, :], cof[..., 0, :])
    return np.swapaxes(cof, -1, -2) / det[..., None, None], det


def gradient_integrals(X: np.ndarray, rule: ReferenceRule, affine: bool) -> np.ndarray:
    """D[(a, b), e, (i, j)] = int dN_i/dx_a dN_j/dx_b dV, shape (9, e, 100), m.

    Component-major, so each of the 9 components is contiguous for the scatter.
    """
    if affine:
        invJ, det = inverse_and_det(jacobians(X, None))
        W = np.einsum("e,eka,elb->abekl", np.abs(det), invJ, invJ, optimize=True)
        A = np.einsum("q,qcp->cp", rule.weights, rule.GG)  # exact: integrand of degree 2
        return (W.reshape(-1, 9) @ A).reshape(9, -1, 100)
    invJ, det = inverse_and_det(jacobians(X, rule))
    dx = np.abs(det) * rule.weights  # (e, q)
    W = np.einsum("eq,eqka,eqlb->abeqkl", dx, invJ, invJ, optimize=True)
    nq = rule.weights.size
    return (W.reshape(-1, 9 * nq) @ rule.GG.reshape(9 * nq, 100)).reshape(9, -1, 100)


def mass_integrals(X: np.ndarray, rule: ReferenceRule, affine: bool) -> np.ndarray:
    """m[e, (i, j)] = int N_i N_j dV, shape (e, 100), m^3."""
    if affine:
        _, det = inverse_and_det(jacobians(X, None))
        return np.abs(det)[:, None] * (rule.weights @ rule.NN)[None, :]
    _, det = inverse_and_det(jacobians(X, rule))
    return (np.abs(det) * rule.weights) @ rule.NN


@dataclass(frozen=True)
class NodePattern:
    """Sparsity of the (node, node) coupling of a P2 mesh, CSR order.

    ``position[e, i * 10 + j]`` is where the element pair (i, j) lands in
    the CSR data; ``transpose[p]`` is the position of the mirrored entry.
    """

    indptr: np.ndarray
    indices: np.ndarray
    position: np.ndarray  # (e, 100)
    transpose: np.ndarray  # (nnz,)
    n_nodes: int

    @classmethod
    def of(cls, conn: np.ndarray, n_nodes: int) -> NodePattern:
        conn = np.asarray(conn, np.int64)
        key = (np.repeat(conn, 10, axis=1) * n_nodes + np.tile(conn, (1, 10))).ravel()
        uniq, position = np.unique(key, return_inverse=True)
        rows, cols = np.divmod(uniq, n_nodes)
        indptr = np.zeros(n_nodes + 1, np.int64)
        np.cumsum(np.bincount(rows, minlength=n_nodes), out=indptr[1:])
        transpose = np.searchsorted(uniq, cols * n_nodes + rows)
        return cls(indptr, cols, position.reshape(conn.shape[0], 100), transpose, n_nodes)

    @property
    def nnz(self) -> int:
        return int(self.indices.size)

    def scatter(self, values: np.ndarray, elements: np.ndarray) -> np.ndarray:
        """Sum element values (c, 100) of ``elements`` (c,) into pattern order (nnz,)."""
        return np.bincount(self.position[elements].ravel(), weights=values.ravel(),
                           minlength=self.nnz)

    def csr(self, data: np.ndarray) -> sp.csr_matrix:
        n = self.n_nodes
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(n, n))


def assemble_p2(X: np.ndarray, conn: np.ndarray, n_nodes: int, lam: float | np.ndarray,
                mu: float | np.ndarray, straight: np.ndarray | bool, stiffness_order: int = 4,
                mass_order: int = 7,
                rho: float | np.ndarray = 1.0) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Elasticity stiffness and scalar mass of a P2 tetrahedral mesh.

    Parameters
    ----------
    X : (e, 10, 3) array
        Node coordinates per element, m (local ``ElementTetP2`` order).
    conn : (e, 10) int array
        Global node ids per element.
    n_nodes : int
        Number of nodes.
    lam, mu : float or (e,) array
        Lame parameters, Pa: one material, or each element's (a link of several
        materials).
    straight : bool or (e,) bool array
        Straight-sided (affine) elements: constant Jacobian from the vertices,
        integrals exact. The others are isoparametric (curved) P2 elements.
    stiffness_order, mass_order : int
        Quadrature orders of curved elements: 4 is skfem's default for P2;
        the curved mass integrand N_i N_j det J has degree 7, so order 7
        integrates it exactly.
    rho : float or (e,) array
        Density, kg/m^3, one or each element's; 1 gives the volume form.

    Returns
    -------
    K : (3 n_nodes, 3 n_nodes) CSR
        Stiffness, N/m, with DOF 3 n + a = component a of node n.
    Ms : (n_nodes, n_nodes) CSR
        Scalar mass int rho N_i N_j dV, kg (m^3 with rho = 1).
    """
    pattern = NodePattern.of(conn, n_nodes)
    e = conn.shape[0]
    straight = np.broadcast_to(np.asarray(straight, bool), (e,))
    # one material: the gradient integrals are scattered once and scaled after; several:
    # the lam- and the mu-weighted integrals are scattered apart
    uniform = np.ndim(lam) == 0 and np.ndim(mu) == 0 and np.ndim(rho) == 0
    lam_e, mu_e, rho_e = (np.broadcast_to(np.asarray(x, float), (e,)) for x in (lam, mu, rho))
    D = np.zeros((9, pattern.nnz))
    Dm = D if uniform else np.zeros((9, pattern.nnz))
    ms = np.zeros(pattern.nnz)
    for affine in (True, False):
        elements = np.flatnonzero(straight == affine)
        if elements.size == 0:
            continue
        k_rule = ReferenceRule.of_order(4 if affine else stiffness_order)
        m_rule = k_rule if affine else ReferenceRule.of_order(mass_order)
        batch = max(1, _BATCH_DOUBLES // (900 + 81 * (1 if affine else k_rule.weights.size)))
        for start in range(0, elements.size, batch):
            part = elements[start:start + batch]
            De = gradient_integrals(X[part], k_rule, affine)
            me = mass_integrals(X[part], m_rule, affine)
            if uniform:
                for ab in range(9):
                    D[ab] += pattern.scatter(De[ab], part)
                ms += pattern.scatter(me, part)
                continue
            for ab in range(9):
                D[ab] += pattern.scatter(lam_e[part, None] * De[ab], part)
                Dm[ab] += pattern.scatter(mu_e[part, None] * De[ab], part)
            ms += pattern.scatter(rho_e[part, None] * me, part)
    if uniform:
        K = _stiffness_from_gradients(D, float(lam), float(mu), pattern)
        return K, _symmetric_csr(float(rho) * ms, pattern)
    return _stiffness_from_gradients(D, 1.0, 1.0, pattern, Dm), _symmetric_csr(ms, pattern)


def _stiffness_from_gradients(D: np.ndarray, lam: float, mu: float,
                              pattern: NodePattern, Dm: np.ndarray | None = None
                              ) -> sp.csr_matrix:
    """K blocks lam D + mu Dm^T + mu tr(Dm) 1 per node pair, as CSR (3n, 3n) (Dm = D for
    one material; else D and Dm hold the lam- and mu-weighted integrals, lam = mu = 1).

    ``D`` is component-major (9, nnz), so every step is a contiguous 1-D pass.
    """
    T = pattern.transpose
    # Exact symmetry: the mirrored entry (c, r) holds D^T of (r, c) up to the
    # rounding order of the sums.
    sym = [0.5 * (D[3 * a + b] + D[3 * b + a][T]) for a in range(3) for b in range(3)]
    symm = sym if Dm is None else [0.5 * (Dm[3 * a + b] + Dm[3 * b + a][T])
                                   for a in range(3) for b in range(3)]
    trace = symm[0] + symm[4] + symm[8]
    blocks = np.empty((pattern.nnz, 3, 3))
    for a in range(3):
        for b in range(3):
            blocks[:, a, b] = lam * sym[3 * a + b] + mu * symm[3 * b + a]
        blocks[:, a, a] += mu * trace
    n = 3 * pattern.n_nodes
    return sp.bsr_matrix((blocks, pattern.indices, pattern.indptr), shape=(n, n)).tocsr()


def _symmetric_csr(values: np.ndarray, pattern: NodePattern) -> sp.csr_matrix:
    return pattern.csr(0.5 * (values + values[pattern.transpose]))


def vector_mass(Ms: sp.csr_matrix) -> sp.csr_matrix:
    """kron(Ms, 1_3) without explicit zeros: DOF 3 n + a couples only to 3 m + a.

    Parameters
    ----------
    Ms : (n, n) CSR
        Scalar mass, kg.

    Returns
    -------
    (3 n, 3 n) CSR

    Examples
    --------
    >>> M = vector_mass(sp.csr_matrix(np.array([[2.0, 1.0], [1.0, 2.0]])))
    >>> bool((M != sp.kron(np.array([[2.0, 1.0], [1.0, 2.0]]), np.eye(3))).nnz == 0), M.nnz
    (True, 12)
    """
    Ms = sp.csr_matrix(Ms)
    rowlen = np.diff(Ms.indptr)
    lengths = np.repeat(rowlen, 3)  # row 3 r + a has the entries of row r
    indptr = np.zeros(lengths.size + 1, np.int64)
    np.cumsum(lengths, out=indptr[1:])
    # Entry k of new row (r, a) is entry Ms.indptr[r] + k of row r.
    shift = np.repeat(indptr[:-1] - np.repeat(Ms.indptr[:-1], 3), lengths)
    source = np.arange(indptr[-1]) - shift
    component = np.repeat(np.tile(np.arange(3), rowlen.size), lengths)
    n = 3 * Ms.shape[0]
    return sp.csr_matrix((Ms.data[source], 3 * Ms.indices[source] + component, indptr),
                         shape=(n, n))
