"""Slender links as 3D Euler-Bernoulli (Rayleigh) beams assembled with scikit-fem.

Per element, in its local frame (x along the element, see
:func:`pipeline.fem.section.element_frames`), the fields are

* axial ``u_x`` and torsion ``theta_x``: linear (``ElementLineP1``);
* bending in the x-y plane: transverse ``u_y`` cubic (``ElementLineHermite``),
  rotation ``theta_z = d u_y / dx``;
* bending in the x-z plane: transverse ``u_z`` cubic, ``theta_y = -d u_z / dx``.

Stiffness: ``EA u_x'^2 + GJ theta_x'^2 + E Iz u_y''^2 + E Iy u_z''^2``.
Consistent mass: translation ``rho A |u|^2`` plus the section's rotary
inertia ``theta^T (tr(S_sec) 1 - S_sec) theta`` with
``S_sec = rho (Iz e_y e_y^T + Iy e_z e_z^T)`` (Rayleigh beam): the material
point ``x + s`` of the section moves with ``u + theta x s``, so the mass
matrix is exactly the kinetic energy the mass invariants
(:func:`pipeline.fem.beam_moments.beam_moments`) are built from.

The element matrices come from scikit-fem on a 1D ``MeshLine1`` holding every
element on its own arc-length segment ``[0, L_e]`` (one assembly call per form
for the whole link; an element matrix only depends on its length). Starting
each element at 0 matters: ``ElementLineHermite`` builds its basis from
monomials in the global coordinate, which loses digits ~ (s / L_e)^3 far from
the origin. Unit-coefficient matrices are scaled by the per-element section
constants, rotated to the link frame and scattered, all vectorised.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from pipeline.core.errors import ConfigError, MeshError
from pipeline.core.progress import stage
from pipeline.fem.beam_moments import beam_moments
from pipeline.fem.model import FemModel
from pipeline.fem.section import BeamSection, check_section, element_frames
from pipeline.meshing.mesh_data import MeshData

__all__ = ["SECTION_COLUMNS", "assemble_beam", "beam_moments", "sections_by_member"]

logger = logging.getLogger(__name__)

#: Column order of ``FemModel.extras["sections"]`` (one row per element).
SECTION_COLUMNS = ("A", "Iy", "Iz", "J", "E", "G", "rho")

# Local DOF numbers in the element's (12,) vector [u0, theta0, u1, theta1].
_AXIAL = np.array([0, 6])
_TORSION = np.array([3, 9])
_PLANE_XY = np.array([1, 5, 7, 11])  # u_y, theta_z = +u_y'
_PLANE_XZ = np.array([2, 4, 8, 10])  # u_z, theta_y = -u_z'
_XZ_SIGN = np.array([1.0, -1.0, 1.0, -1.0])


def assemble_beam(
    mesh: MeshData, sections: BeamSection | Sequence[BeamSection], name: str
) -> FemModel:
    """Free-free stiffness and consistent mass of a beam link.

    Parameters
    ----------
    mesh : MeshData
        ``kind == "beam"`` with ``cells["line"]`` (k, 2); points (n, 3) in m,
        link frame. Every point must belong to an element.
    sections : BeamSection or sequence of k BeamSection
        One section for all elements, or one per line element.
    name : str
        Link name, used in error messages and as ``FemModel.name``.

    Returns
    -------
    FemModel
        ``kind="beam"``, ``nodes = mesh.points``, ``node_dofs`` (n, 6) =
        (ux, uy, uz, rx, ry, rz) in the link frame (m, rad), K in N/m, N,
        N m, M in kg, kg m, kg m^2. ``extras``: ``"cells"`` (k, 2),
        ``"sections"`` (k, 7) float in :data:`SECTION_COLUMNS` order (SI),
        ``"frames"`` (k, 3, 3) with rows e_x, e_y, e_z, ``"lengths"`` (k,) m.

    Raises
    ------
    ConfigError
        Wrong mesh kind, wrong number of sections, bad section values, a
        ``y_axis`` parallel to an element.
    MeshError
        No line cells, zero-length elements, points not on any element.

    Examples
    --------
    >>> mesh = MeshData(points=[[0, 0, 0], [1, 0, 0]], cells={"line": [[0, 1]]}, kind="beam")
    >>> s = BeamSection(A=1e-4, Iy=1e-9, Iz=1e-9, J=2e-9, E=2e11, G=8e10, rho=7800.0)
    >>> model = assemble_beam(mesh, s, "bar")
    >>> ux = np.tile([1.0, 0, 0, 0, 0, 0], 2)      # rigid translation along x
    >>> model.n_dof, round(float(ux @ model.mass @ ux), 12)   # rho A L, kg
    (12, 0.78)
    """
    where = f"link '{name}'"
    cells = _line_cells(mesh, where)
    secs = _sections_per_element(sections, len(cells), where)
    props = np.array([[getattr(s, f) for f in SECTION_COLUMNS] for s in secs], dtype=float)
    delta = mesh.points[cells[:, 1]] - mesh.points[cells[:, 0]]
    lengths = np.linalg.norm(delta, axis=1)
    if np.any(lengths <= 1e-12 * max(float(np.abs(mesh.points).max()), 1.0)):
        e = int(np.argmin(lengths))
        raise MeshError(f"{where}: beam element {e} {cells[e].tolist()} has zero length")
    y_axes = np.array([s.y_axis if s.y_axis is not None else (np.nan,) * 3 for s in secs])
    frames = element_frames(delta / lengths[:, None], y_axes, where)
    with stage(f"assembling beam link '{name}' ({len(cells)} elements)"):
        k_loc, m_loc = local_matrices(lengths, props)
        k_link, m_link = _to_link_frame(k_loc, frames), _to_link_frame(m_loc, frames)
        node_dofs = np.arange(6 * mesh.n_points).reshape(mesh.n_points, 6)
        elem_dofs = node_dofs[cells].reshape(len(cells), 12)
        stiffness = _scatter(k_link, elem_dofs, node_dofs.size)
        mass = _scatter(m_link, elem_dofs, node_dofs.size)
    extras = {"cells": cells, "sections": props, "frames": frames, "lengths": lengths}
    return FemModel(name, "beam", mesh.points, node_dofs, stiffness, mass, extras)


def sections_by_member(
    mesh: MeshData, member_sections: Sequence[BeamSection], name: str
) -> tuple[BeamSection, ...]:
    """One section per line element from one section per polyline member.

    Member ``i`` is the node group ``mesh.groups["member_<i>"]`` (as written by
    the gmsh beam mesher); an element belongs to the member holding both its
    nodes.

    Parameters
    ----------
    mesh : MeshData
        Beam mesh with ``cells["line"]`` (k, 2) and the member groups.
    member_sections : sequence of BeamSection
        Section of member 0, 1, ...
    name : str
        Link name for error messages.

    Returns
    -------
    tuple of k BeamSection, in cell order.

    Raises
    ------
    ConfigError
        Missing member group, or an element in no member or in two.

    Examples
    --------
    >>> mesh = MeshData(points=[[0, 0, 0], [1, 0, 0], [1, 1, 0]], cells={"line": [[0, 1], [1, 2]]},
    ...                 kind="beam", groups={"member_0": [0, 1], "member_1": [1, 2]})
    >>> a, b = (BeamSection(A=x, Iy=1, Iz=1, J=1, E=1, G=1, rho=1) for x in (1.0, 2.0))
    >>> [s.A for s in sections_by_member(mesh, [a, b], "frame")]
    [1.0, 2.0]
    """
    where = f"link '{name}'"
    cells = _line_cells(mesh, where)
    member_of = np.full(len(cells), -1)
    for i in range(len(member_sections)):
        group = mesh.groups.get(f"member_{i}")
        if group is None:
            raise ConfigError(f"{where}: sections given for {len(member_sections)} members but "
                              f"the mesh has no node group 'member_{i}'")
        inside = np.all(np.isin(cells, group), axis=1)
        if np.any(inside & (member_of >= 0)):
            raise ConfigError(f"{where}: elements belong to members "
                              f"{member_of[inside & (member_of >= 0)].max()} "
                              f"and {i}; expected each element in one member")
        member_of[inside] = i
    if np.any(member_of < 0):
        e = int(np.flatnonzero(member_of < 0)[0])
        raise ConfigError(f"{where}: element {e} {cells[e].tolist()} lies in no member group "
                          f"'member_0'..'member_{len(member_sections) - 1}'")
    return tuple(member_sections[i] for i in member_of)


def local_matrices(lengths: np.ndarray, props: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Element stiffness and consistent mass (k, 12, 12) in the element frames.

    Parameters
    ----------
    lengths : (k,) element lengths, m.
    props : (k, 7) section constants in :data:`SECTION_COLUMNS` order, SI.

    Returns
    -------
    (K, M) : two (k, 12, 12) arrays; local DOF order per element
        [ux, uy, uz, rx, ry, rz] of node 0, then of node 1.
    """
    A, Iy, Iz, J, E, G, rho = props.T
    p1_k, p1_m, h_k, h_m, h_g = _unit_matrices(lengths)
    flip = np.outer(_XZ_SIGN, _XZ_SIGN)
    K = np.zeros((len(lengths), 12, 12))
    M = np.zeros_like(K)
    _add(K, _AXIAL, (E * A)[:, None, None] * p1_k)
    _add(K, _TORSION, (G * J)[:, None, None] * p1_k)
    _add(K, _PLANE_XY, (E * Iz)[:, None, None] * h_k)
    _add(K, _PLANE_XZ, (E * Iy)[:, None, None] * h_k * flip)
    _add(M, _AXIAL, (rho * A)[:, None, None] * p1_m)
    _add(M, _TORSION, (rho * (Iy + Iz))[:, None, None] * p1_m)
    _add(M, _PLANE_XY, (rho * A)[:, None, None] * h_m + (rho * Iz)[:, None, None] * h_g)
    _add(M, _PLANE_XZ,
         ((rho * A)[:, None, None] * h_m + (rho * Iy)[:, None, None] * h_g) * flip)
    return K, M


def _unit_matrices(lengths: np.ndarray) -> tuple[np.ndarray, ...]:
    """scikit-fem element matrices with unit coefficients, one call per form.

    Returns P1 int u'v', P1 int uv (k, 2, 2) and Hermite int u''v'', int uv,
    int u'v' (k, 4, 4); Hermite local order [u0, u0', u1, u1'] (d/ds).
    """
    from skfem import Basis, BilinearForm, ElementLineHermite, ElementLineP1, MeshLine1
    from skfem.helpers import d, dd

    k = len(lengths)
    coords = np.zeros(2 * k)
    coords[1::2] = lengths  # element e on [0, L_e]: points 2e and 2e + 1
    connectivity = np.ascontiguousarray(np.arange(2 * k).reshape(k, 2).T)  # skfem wants C order
    line = MeshLine1(coords[None, :], connectivity)
    p1, herm = Basis(line, ElementLineP1()), Basis(line, ElementLineHermite())

    grad_grad = BilinearForm(lambda u, v, _: d(u)[0] * d(v)[0])
    value_value = BilinearForm(lambda u, v, _: u * v)
    curv_curv = BilinearForm(lambda u, v, _: dd(u)[0, 0] * dd(v)[0, 0])
    return tuple(form.coo_data(basis).tolocal() for form, basis in (
        (grad_grad, p1), (value_value, p1), (curv_curv, herm), (value_value, herm),
        (grad_grad, herm)))


def _add(target: np.ndarray, idx: np.ndarray, block: np.ndarray) -> None:
    target[:, idx[:, None], idx[None, :]] += block


def _to_link_frame(local: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """T^T A T per element with T = diag(R, R, R, R), R = frames[e] (rows e_x, e_y, e_z)."""
    k = len(frames)
    blocks = local.reshape(k, 4, 3, 4, 3)
    out = np.einsum("kip,kaibj,kjq->kapbq", frames, blocks, frames, optimize=True)
    return out.reshape(k, 12, 12)


def _scatter(element: np.ndarray, elem_dofs: np.ndarray, n_dof: int) -> sp.csr_matrix:
    rows = np.repeat(elem_dofs, 12, axis=1).ravel()
    cols = np.tile(elem_dofs, (1, 12)).ravel()
    A = sp.csr_matrix((element.ravel(), (rows, cols)), shape=(n_dof, n_dof))
    return ((A + A.T) * 0.5).tocsr()  # remove rounding asymmetry of the rotation


def _line_cells(mesh: MeshData, where: str) -> np.ndarray:
    if mesh.kind != "beam":
        raise ConfigError(f"{where}: mesh.kind: expected 'beam', got {mesh.kind!r}")
    cells = np.asarray(mesh.cells.get("line", np.zeros((0, 2))), dtype=np.int64)
    if cells.ndim != 2 or cells.shape[1] != 2 or len(cells) == 0:
        raise MeshError(f"{where}: mesh.cells['line']: expected (k, 2) with k >= 1, "
                        f"got shape {cells.shape}")
    if cells.min() < 0 or cells.max() >= mesh.n_points:
        raise MeshError(f"{where}: mesh.cells['line']: node index out of range 0..{mesh.n_points - 1}")
    unused = np.setdiff1d(np.arange(mesh.n_points), cells.ravel())
    if len(unused):
        raise MeshError(f"{where}: mesh points {unused[:10].tolist()} belong to no beam element "
                        f"(their DOFs would have no stiffness or mass)")
    return cells


def _sections_per_element(sections, k: int, where: str) -> tuple[BeamSection, ...]:
    if isinstance(sections, BeamSection):
        sections = (sections,) * k
    sections = tuple(sections)
    if len(sections) != k:
        raise ConfigError(f"{where}: sections: expected 1 or {k} (one per line element), "
                          f"got {len(sections)}")
    first_index: dict[int, int] = {}  # check each distinct object once, name its first use
    for i, s in enumerate(sections):
        first_index.setdefault(id(s), i)
    for i in first_index.values():
        if not isinstance(sections[i], BeamSection):
            raise ConfigError(f"{where}: sections[{i}]: expected a BeamSection, "
                              f"got {type(sections[i]).__name__}")
        check_section(sections[i], f"{where}: sections[{i}]")
    return sections
