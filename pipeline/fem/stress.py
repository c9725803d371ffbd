"""Stress recovery from nodal displacements: P2 solids and Hermite beams.

* Solids: the stress of each P2 tetrahedron is evaluated at its 10 nodes,
  ``sigma = lam tr(eps) 1 + 2 mu eps`` with ``eps`` the symmetric gradient of the element's
  own quadratic displacement (isoparametric Jacobian at the node), and each node takes the
  plain mean over the elements that share it. Pure bending (a linear stress field) is
  recovered exactly; elsewhere the error is of the order of the element's stress jump.
  Voigt order ``[xx, yy, zz, yz, xz, xy]``, Pa.
* Beams: section resultants at every node, ``[N, Vy, Vz, T, My, Mz]`` (N, N m) in the
  axes of the element(s) ending there: ``N = EA u_x'``, ``T = GJ theta_x'``,
  ``Mz = E Iz u_y''``, ``My = -E Iy u_z''``, ``Vy = dMz/ds``, ``Vz = -dMy/ds`` from the
  Hermite cubic (exact for end loads). A node shared by several elements takes their mean
  (exact along a straight member; at a corner the axes differ and the first element's
  value is kept). The axial stress at a point (y, z) of the section is
  ``N / A - Mz y / Iz + My z / Iy`` (:func:`beam_fibre_stress`).

Everything is linear in the displacement, so the functions take a block of displacement
vectors (one per mode) and return a block of fields: the *stress modes*.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from pipeline.fem.model import FemModel
from pipeline.fem.p2_kernel import EDGES, inverse_and_det, p2_shape

__all__ = [
    "RESULTANTS",
    "VOIGT",
    "beam_fibre_stress",
    "beam_nodal_resultants",
    "principal_stresses",
    "solid_nodal_stress",
    "stress_modes",
    "tensor_to_voigt",
    "voigt_to_tensor",
    "von_mises",
]

VOIGT = ("xx", "yy", "zz", "yz", "xz", "xy")
RESULTANTS = ("N", "Vy", "Vz", "T", "My", "Mz")
#: tensor indices (row, column) of each Voigt component
_VI, _VJ = np.array([0, 1, 2, 1, 0, 0]), np.array([0, 1, 2, 2, 2, 1])


def voigt_to_tensor(s: np.ndarray) -> np.ndarray:
    """(..., 3, 3) symmetric tensors of Voigt vectors (..., 6) in :data:`VOIGT` order."""
    s = np.asarray(s, dtype=float)
    T = np.zeros(s.shape[:-1] + (3, 3))
    T[..., _VI, _VJ] = s
    T[..., _VJ, _VI] = s
    return T


def tensor_to_voigt(T: np.ndarray) -> np.ndarray:
    """(..., 6) Voigt vectors of symmetric tensors (..., 3, 3)."""
    return np.asarray(T)[..., _VI, _VJ]


def stress_modes(model: FemModel, U: np.ndarray) -> np.ndarray:
    """(m, n_nodes, 6) stress (solids, Voigt, Pa) or section resultants (beams, N and
    N m) per unit of each column of U (n_dof, m)."""
    if model.kind == "beam":
        return beam_nodal_resultants(model, U)
    return solid_nodal_stress(model, U)


def _reference_nodes() -> np.ndarray:
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    return np.vstack([V, [(V[i] + V[j]) / 2 for i, j in EDGES]])


def solid_nodal_stress(model: FemModel, U: np.ndarray, chunk: int = 1024) -> np.ndarray:
    """(m, n_nodes, 6) nodal-averaged P2 stress, Pa, of displacements U (n_dof, m), m.

    All columns at once, ``chunk`` elements at a time: per element one batched product of
    its shape-function gradients at its nodes (30, 10) with its nodal displacements
    (10, 3 m), then one sparse sum per chunk into the nodes.
    """
    U = np.asarray(U, dtype=float).reshape(model.n_dof, -1)
    m = U.shape[1]
    cells = np.asarray(model.extras["cells"])  # (e, 10) model node ids, P2 local order
    lam_e, mu_e = model.extras["cell_materials"].lame  # (e,) each, Pa
    _, dN = p2_shape(_reference_nodes().T)  # (10 points, 10 functions, 3)
    count = np.bincount(cells.ravel(), minlength=model.n_nodes).astype(float)
    total = np.zeros((model.n_nodes, 6 * m))
    for s in range(0, cells.shape[0], chunk):
        c = cells[s:s + chunk]
        e = c.shape[0]
        lam, mu = lam_e[s:s + chunk, None, None], mu_e[s:s + chunk, None, None]
        J = np.einsum("eni,pnk->epik", model.nodes[c], dN, optimize=True)  # dx_i/dxi_k
        invJ, _ = inverse_and_det(J)
        G = np.einsum("pnk,epka->epan", dN, invJ, optimize=True)  # dN_n/dx_a at point p
        u = U[model.node_dofs[c]]  # (e, 10, 3, m)
        g = np.matmul(G.reshape(e, 30, 10), u.reshape(e, 10, 3 * m))
        # g[:, p, 3 a + b] = du_b/dx_a at the element's node p
        g = g.reshape(e, 10, 9, m)
        tr = g[:, :, 0] + g[:, :, 4] + g[:, :, 8]
        tr *= lam
        sigma = np.empty((e, 10, 6, m))
        for k, (i, j) in enumerate(zip(_VI, _VJ)):
            if i == j:  # sigma_ii = 2 mu eps_ii + lam tr(eps)
                np.multiply(g[:, :, 4 * i], 2.0 * mu, out=sigma[:, :, k])
                sigma[:, :, k] += tr
            else:  # sigma_ij = mu (du_i/dx_j + du_j/dx_i)
                np.add(g[:, :, 3 * i + j], g[:, :, 3 * j + i], out=sigma[:, :, k])
                sigma[:, :, k] *= mu
        # the chunk's own nodes only: a sum into all nodes would touch n_nodes x 6 m
        nodes, local = np.unique(c, return_inverse=True)
        to_nodes = sp.csr_matrix((np.ones(e * 10), (local.ravel(), np.arange(e * 10))),
                                 shape=(nodes.size, e * 10))
        total[nodes] += to_nodes @ sigma.reshape(e * 10, 6 * m)
    total /= np.maximum(count, 1.0)[:, None]
    return np.ascontiguousarray(total.reshape(model.n_nodes, 6, m).transpose(2, 0, 1))


def beam_nodal_resultants(model: FemModel, U: np.ndarray) -> np.ndarray:
    """(m, n_nodes, 6) section resultants [N, Vy, Vz, T, My, Mz] (N, N m) in the element
    axes, of displacements U (n_dof, m) (m, rad)."""
    from pipeline.fem.beam import SECTION_COLUMNS

    U = np.asarray(U, dtype=float).reshape(model.n_dof, -1)
    cells, frames = model.extras["cells"], model.extras["frames"]
    Ls, props = model.extras["lengths"], model.extras["sections"]
    col = {k: props[:, SECTION_COLUMNS.index(k)] for k in SECTION_COLUMNS}
    k = len(cells)
    dofs = model.node_dofs[cells]  # (k, 2, 6)
    out = np.zeros((U.shape[1], model.n_nodes, 6))
    first = np.full(model.n_nodes, -1)
    for e in range(k):  # a node's elements: same direction -> mean; a corner -> first one
        for n in cells[e]:
            if first[n] < 0:
                first[n] = e
    same = np.array([[abs(frames[e, 0] @ frames[first[n], 0]) > 1 - 1e-9 for n in cells[e]]
                     for e in range(k)])  # (k, 2)
    for a in range(U.shape[1]):
        d = U[dofs, a]  # (k, 2, 6) link axes
        t = np.einsum("kij,knj->kni", frames, d[..., :3])  # element axes
        r = np.einsum("kij,knj->kni", frames, d[..., 3:])
        L = Ls
        ux = (t[:, 1, 0] - t[:, 0, 0]) / L
        tx = (r[:, 1, 0] - r[:, 0, 0]) / L
        # Hermite second derivatives at the two ends, x-y plane (slope = theta_z) and
        # x-z plane (slope = -theta_y); third derivative constant
        v = _hermite_curvatures(t[:, 0, 1], r[:, 0, 2], t[:, 1, 1], r[:, 1, 2], L)
        w = _hermite_curvatures(t[:, 0, 2], -r[:, 0, 1], t[:, 1, 2], -r[:, 1, 1], L)
        res = np.zeros((k, 2, 6))
        res[..., 0] = (col["E"] * col["A"] * ux)[:, None]
        res[..., 3] = (col["G"] * col["J"] * tx)[:, None]
        res[..., 5] = (col["E"] * col["Iz"])[:, None] * v[0]
        res[..., 4] = -(col["E"] * col["Iy"])[:, None] * w[0]
        res[..., 1] = (col["E"] * col["Iz"] * v[1])[:, None]  # Vy = dMz/ds
        res[..., 2] = (col["E"] * col["Iy"] * w[1])[:, None]  # Vz = -dMy/ds
        acc = np.zeros((model.n_nodes, 6))
        cnt = np.zeros(model.n_nodes)
        np.add.at(acc, cells[same], res[same])
        np.add.at(cnt, cells[same], 1.0)
        out[a] = acc / np.maximum(cnt, 1.0)[:, None]
    return out


def _hermite_curvatures(v0, s0, v1, s1, L):
    """((k, 2) second derivative at both ends, (k,) third derivative) of the cubic with
    end values v0, v1 and slopes s0, s1 on [0, L]."""
    c0 = (-6 * v0 - 4 * L * s0 + 6 * v1 - 2 * L * s1) / L ** 2
    c1 = (6 * v0 + 2 * L * s0 - 6 * v1 + 4 * L * s1) / L ** 2
    return np.stack([c0, c1], axis=1), (c1 - c0) / L


def beam_fibre_stress(resultants: np.ndarray, A: float, Iy: float, Iz: float, y: float,
                      z: float) -> np.ndarray:
    """(...,) axial stress (Pa) at the section point (y, z) m of resultants (..., 6)."""
    r = np.asarray(resultants, dtype=float)
    return r[..., 0] / A - r[..., 5] * y / Iz + r[..., 4] * z / Iy


def von_mises(s: np.ndarray) -> np.ndarray:
    """(...,) von Mises stress of Voigt stresses (..., 6), Pa.

    Examples
    --------
    >>> float(von_mises(np.array([100.0, 0, 0, 0, 0, 0])))   # uniaxial
    100.0
    >>> round(float(von_mises(np.array([0.0, 0, 0, 0, 0, 50.0]))), 6)   # shear: sqrt(3) tau
    86.60254
    """
    s = np.asarray(s, dtype=float)
    xx, yy, zz, yz, xz, xy = (s[..., i] for i in range(6))
    return np.sqrt(0.5 * ((xx - yy) ** 2 + (yy - zz) ** 2 + (zz - xx) ** 2)
                   + 3.0 * (xy ** 2 + yz ** 2 + xz ** 2))


def principal_stresses(s: np.ndarray) -> np.ndarray:
    """(..., 3) principal stresses, descending, of Voigt stresses (..., 6), Pa."""
    return np.linalg.eigvalsh(voigt_to_tensor(s))[..., ::-1]
