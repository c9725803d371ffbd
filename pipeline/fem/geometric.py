"""Geometric (stress) stiffness of beam links and the load cases that prestress them.

A member carrying an axial force N resists lateral deflection by
``N int (u_x' du_x' + u_y' du_y' + u_z' du_z') dx`` -- the second-order part of the
Green-Lagrange strain, ``eps = u_x' + (u_x'^2 + u_y'^2 + u_z'^2) / 2``, times the
prestress. :func:`beam_geometric_stiffness` assembles that form for per-element axial
forces (constant along an element, as the linear axial field of the element gives
them; torsion-bending (Wagner) terms are left out). For P2 solids the form is
``int sigma_ij du_k/dx_i dv_k/dx_j dV`` with the prestress sigma of the load case
(:func:`solid_modal_geometric_stiffness`, projected on the modes element by element).

The prestress comes from load cases solved on the FE model: :func:`centrifugal_loads`
gives the consistent nodal loads of the six unit centrifugal cases of a link spinning
with angular velocity w about a point o -- the body-force field
``rho (|w|^2 1 - w w^T)(r - o)``, linear in ``r`` and bilinear in w, so it is the sum of
``w_i w_j`` times six unit fields (:data:`CENTRIFUGAL_CASES`).
:func:`acceleration_loads` gives those of a uniform acceleration field (a translational
acceleration of the link, or gravity) along each body axis. Units are SI.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from pipeline.core.errors import ConfigError
from pipeline.fem.beam import (
    _AXIAL,
    _PLANE_XY,
    _PLANE_XZ,
    _XZ_SIGN,
    SECTION_COLUMNS,
    _add,
    _scatter,
    _to_link_frame,
    _unit_matrices,
    local_matrices,
)
from pipeline.fem.model import FemModel

__all__ = ["CENTRIFUGAL_CASES", "INERTIA_CASES", "acceleration_loads", "beam_axial_forces",
           "beam_geometric_stiffness", "centrifugal_fields", "centrifugal_loads",
           "centrifugal_products", "centrifugal_tensor", "inertia_loads",
           "solid_centrifugal_loads", "solid_modal_geometric_stiffness"]

#: The six products of angular-velocity components the centrifugal field is linear in.
CENTRIFUGAL_CASES = ("wx^2", "wy^2", "wz^2", "wx*wy", "wx*wz", "wy*wz")
_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def centrifugal_products(omega: np.ndarray) -> np.ndarray:
    """(6,) the factors of :data:`CENTRIFUGAL_CASES` for an angular velocity (3,) rad/s.

    Examples
    --------
    >>> centrifugal_products(np.array([1.0, 2.0, 3.0])).tolist()
    [1.0, 4.0, 9.0, 2.0, 3.0, 6.0]
    """
    w = np.asarray(omega, dtype=float)
    return np.array([w[i] * w[j] for i, j in _PAIRS])


def centrifugal_tensor(K: np.ndarray) -> np.ndarray:
    """(3, 3, ...) G with ``sum_ij w_i w_j G_ij = sum_c p_c(w) K_c`` from the six case
    blocks K (6, ...) of :data:`CENTRIFUGAL_CASES` (a mixed case split evenly between
    (i, j) and (j, i)): the spin enters as w^T G w, with no case order to know.

    Examples
    --------
    >>> K = np.arange(6.0)
    >>> w = np.array([0.5, -2.0, 1.5])
    >>> float(w @ centrifugal_tensor(K) @ w) == float(centrifugal_products(w) @ K)
    True
    """
    K = np.asarray(K, dtype=float)
    G = np.zeros((3, 3) + K.shape[1:])
    for c, (i, j) in enumerate(_PAIRS):
        G[i, j] += 0.5 * K[c]
        G[j, i] += 0.5 * K[c]
    return G


def centrifugal_fields(axes: np.ndarray | None = None) -> np.ndarray:
    """(6, 3, 3) B_c with ``sum_c p_c(w) B_c = |w|^2 1 - w w^T`` (the centrifugal
    acceleration per unit distance from the spin point), for w given in the axes whose
    columns are ``axes`` (3, 3) (default: the model's own axes).

    Examples
    --------
    >>> w = np.array([0.3, -1.0, 2.0])
    >>> B = np.einsum("c,cij->ij", centrifugal_products(w), centrifugal_fields())
    >>> bool(np.allclose(B, w @ w * np.eye(3) - np.outer(w, w)))
    True
    """
    R = np.eye(3) if axes is None else np.asarray(axes, dtype=float)
    e = np.eye(3)
    out = np.empty((6, 3, 3))
    for c, (i, j) in enumerate(_PAIRS):
        B = np.eye(3) - np.outer(e[i], e[i]) if i == j else \
            -(np.outer(e[i], e[j]) + np.outer(e[j], e[i]))
        out[c] = R @ B @ R.T
    return out


def centrifugal_loads(model: FemModel, origin, axes=None) -> np.ndarray:
    """(6, n_dof) consistent nodal loads of the unit centrifugal cases of a beam link,
    N per (rad/s)^2: case c is the body force rho A B_c (r - origin) along the members.

    Per element the field is linear in arc length, so its Hermite (transverse) and
    linear (axial) interpolations are exact and the loads are the translational part of
    the consistent mass times the field's nodal values and slopes. Point masses added
    to the model are not loaded (their centrifugal force is not in these cases).

    Parameters
    ----------
    model : beam FemModel (:func:`pipeline.fem.beam.assemble_beam`).
    origin : (3,) the spin point, m, link frame (the body-frame origin).
    axes : (3, 3) columns = the axes the angular velocity is given in (body axes).
    """
    _check_beam(model)
    return _beam_linear_field_loads(model, origin, centrifugal_fields(axes))


def _beam_linear_field_loads(model: FemModel, origin, fields) -> np.ndarray:
    """(F, n_dof) consistent loads on the members of the body forces rho A B_f (r - origin)
    for the (F, 3, 3) fields B_f (link axes): exact, the fields being linear along each
    element (:func:`centrifugal_loads`)."""
    cells, frames = model.extras["cells"], model.extras["frames"]
    lengths, props = model.extras["lengths"], model.extras["sections"].copy()
    props[:, [SECTION_COLUMNS.index("Iy"), SECTION_COLUMNS.index("Iz")]] = 0.0
    _, m_trans = local_matrices(lengths, props)  # rho A only: no section rotary inertia
    d = model.nodes[cells] - np.asarray(origin, dtype=float)  # (k, 2, 3)
    elem_dofs = model.node_dofs[cells].reshape(len(cells), 12)
    out = np.zeros((len(fields), model.n_dof))
    for c, B in enumerate(fields):
        a = np.einsum("kij,knj->kni", frames, d @ B.T)  # (k, 2, 3) field, element axes
        slope = np.einsum("kij,jl,kl->ki", frames, B, frames[:, 0, :])  # d a_loc / ds
        field = np.zeros((len(cells), 2, 6))
        field[:, :, :3] = a
        field[:, :, 4] = -slope[:, None, 2]  # theta_y = -d u_z / ds
        field[:, :, 5] = slope[:, None, 1]  # theta_z = +d u_y / ds
        f_loc = np.einsum("kab,kb->ka", m_trans, field.reshape(-1, 12))
        f_link = np.einsum("kip,kai->kap", frames, f_loc.reshape(-1, 4, 3)).reshape(-1, 12)
        np.add.at(out[c], elem_dofs, f_link)
    return out


#: The twelve unit inertia cases of :func:`inertia_loads`: the body force rho x_j e_k
#: (component k proportional to body coordinate j) and, for j = "1", rho e_k.
INERTIA_CASES = tuple(f"{j}->{k}" for j in ("x", "y", "z", "1") for k in ("x", "y", "z"))


def inertia_loads(model: FemModel, origin, axes=None) -> np.ndarray:
    """(4, 3, n_dof) consistent nodal loads of the twelve unit inertia cases, body force
    rho xb_j e_k with xb = [x, y, z, 1] the body coordinates (from ``origin`` along the
    columns of ``axes``, (3, 3), default the link axes): N per (m/s^2 per m) for
    j < 3, N per m/s^2 for j = 3 (:func:`acceleration_loads`).

    Any inertia field of a moving link is their combination: a translational
    acceleration (j = 3), the centrifugal and angular-acceleration fields (j < 3). P2
    solids: the consistent mass times the field's nodal values (exact, the fields being
    linear; point masses included). Beams: the members' consistent loads
    (:func:`centrifugal_loads`) plus each point mass's load at its point.
    """
    R = np.eye(3) if axes is None else np.asarray(axes, dtype=float)
    o = np.asarray(origin, dtype=float)
    out = np.zeros((4, 3, model.n_dof))
    out[3] = acceleration_loads(model, R)
    if model.kind == "beam":
        fields = np.array([np.outer(R[:, k], R[:, j]) for j in range(3) for k in range(3)])
        out[:3] = _beam_linear_field_loads(model, o, fields).reshape(3, 3, -1)
        for pm in model.extras.get("point_masses", ()):
            xb = (np.asarray(pm["position"]) - o) @ R
            for j in range(3):
                for k in range(3):
                    load = np.r_[pm["mass"] * xb[j] * R[:, k], np.zeros(3)]
                    out[j, k] += pm["operator"].T @ load
        return out
    xb = (model.nodes - o) @ R
    for j in range(3):
        for k in range(3):
            field = np.zeros(model.n_dof)
            field[model.node_dofs] = np.outer(xb[:, j], R[:, k])
            out[j, k] = model.mass @ field
    return out


def acceleration_loads(model: FemModel, axes=None) -> np.ndarray:
    """(3, n_dof) consistent nodal loads of a unit uniform acceleration field along each
    of ``axes`` (columns, (3, 3); default the link axes), N per m/s^2: the body force
    rho e_k on every mass of the model, point masses included.

    The consistent mass times the rigid translation e_k (zero rotations) is exactly the
    consistent load of a uniform body force, for beams (with the moments a uniform load
    puts on the Hermite nodes) and solids alike.
    """
    R = np.eye(3) if axes is None else np.asarray(axes, dtype=float)
    out = np.zeros((3, model.n_dof))
    for k in range(3):
        field = np.zeros(model.n_dof)
        field[model.node_dofs[:, :3]] = R[:, k]
        out[k] = model.mass @ field
    return out


def beam_axial_forces(model: FemModel, u: np.ndarray) -> np.ndarray:
    """(k,) axial force of each element, N (tension positive), for nodal displacements
    u (n_dof,) in the link frame: EA times the element's axial strain."""
    _check_beam(model)
    cells, frames = model.extras["cells"], model.extras["frames"]
    EA = model.extras["sections"][:, SECTION_COLUMNS.index("E")] * \
        model.extras["sections"][:, SECTION_COLUMNS.index("A")]
    t = np.asarray(u, dtype=float)[model.node_dofs[cells][:, :, :3]]  # (k, 2, 3)
    stretch = np.einsum("ki,ki->k", frames[:, 0, :], t[:, 1] - t[:, 0])
    return EA * stretch / model.extras["lengths"]


def beam_geometric_stiffness(model: FemModel, axial_force: np.ndarray) -> sp.csr_matrix:
    """(n_dof, n_dof) geometric stiffness of a beam link whose elements carry the axial
    forces ``axial_force`` (k,) N: ``N int (u_x' v_x' + u_y' v_y' + u_z' v_z') ds`` per
    element (linear axial, Hermite transverse interpolation), N/m."""
    _check_beam(model)
    N = np.asarray(axial_force, dtype=float)
    lengths, frames = model.extras["lengths"], model.extras["frames"]
    p1_k, _, _, _, h_g = _unit_matrices(lengths)
    K = np.zeros((len(lengths), 12, 12))
    _add(K, _AXIAL, N[:, None, None] * p1_k)
    _add(K, _PLANE_XY, N[:, None, None] * h_g)
    _add(K, _PLANE_XZ, N[:, None, None] * h_g * np.outer(_XZ_SIGN, _XZ_SIGN))
    elem_dofs = model.node_dofs[model.extras["cells"]].reshape(len(lengths), 12)
    return _scatter(_to_link_frame(K, frames), elem_dofs, model.n_dof)


def solid_centrifugal_loads(model: FemModel, origin, axes=None) -> np.ndarray:
    """(6, n_dof) consistent nodal loads of the unit centrifugal cases of a P2 solid, N per
    (rad/s)^2: the consistent mass times the nodal values of the linear field B_c (r - o)
    (exact: P2 interpolates a linear field exactly)."""
    d = model.nodes - np.asarray(origin, dtype=float)
    out = np.zeros((6, model.n_dof))
    for c, B in enumerate(centrifugal_fields(axes)):
        field = np.zeros(model.n_dof)
        field[model.node_dofs] = d @ B.T
        out[c] = model.mass @ field
    return out


def solid_modal_geometric_stiffness(model: FemModel, u: np.ndarray, Phi: np.ndarray,
                                    batch: int = 20_000) -> np.ndarray:
    """(m, m) Phi^T K_sigma Phi of a P2 solid prestressed by the displacement u (n_dof,):
    ``int sigma_ij dphi_k/dx_i dpsi_k/dx_j dV`` with sigma the element stress of u at the
    quadrature points (degree-3 rule: exact for straight elements), Phi (n_dof, m)."""
    from pipeline.fem.p2_kernel import ReferenceRule, inverse_and_det

    cells = np.asarray(model.extras["cells"])
    lam_e, mu_e = model.extras["cell_materials"].lame  # (e,) each, Pa
    rule = ReferenceRule.of_order(3)
    U = np.asarray(u, dtype=float)[model.node_dofs]  # (N, 3)
    P = np.asarray(Phi, dtype=float)[model.node_dofs]  # (N, 3, m)
    m = P.shape[-1]
    out = np.zeros((m, m))
    for start in range(0, len(cells), batch):
        c = cells[start:start + batch]
        J = np.einsum("eni,qnk->eqik", model.nodes[c], rule.dN, optimize=True)
        invJ, det = inverse_and_det(J)
        G = np.einsum("qnk,eqka->eqna", rule.dN, invJ, optimize=True)  # dN_n/dx_a
        grad = np.einsum("eqna,enb->eqba", G, U[c], optimize=True)  # du_b/dx_a at [b, a]
        eps = 0.5 * (grad + np.swapaxes(grad, -1, -2))
        tr = np.trace(eps, axis1=-2, axis2=-1)
        lam, mu = lam_e[start:start + batch, None], mu_e[start:start + batch, None]
        sig = 2 * mu[..., None, None] * eps + (lam * tr)[..., None, None] * np.eye(3)
        w = np.abs(det) * rule.weights  # (e, q)
        S = np.einsum("eq,eqna,eqab,eqpb->enp", w, G, sig, G, optimize=True)  # (e, 10, 10)
        Pe = P[c].reshape(len(c), 10, 3 * m)  # (e, 10, 3 m)
        # sum_enpk S_enp Pe_enkx Pe_epky in two steps, the second one a single GEMM
        T = np.matmul(np.swapaxes(S, 1, 2), Pe)  # (e, 10, 3 m): [e, p, (k, x)]
        out += T.reshape(-1, m).T @ Pe.reshape(-1, m)
    return 0.5 * (out + out.T)


def _check_beam(model: FemModel) -> None:
    if model.kind != "beam":
        raise ConfigError(f"link {model.name!r}: geometric stiffness is available for beam "
                          f"links only (this one is a {model.kind})")
