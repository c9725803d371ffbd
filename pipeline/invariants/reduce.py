"""Reduce one link: geometry -> mesh -> FE model -> modes -> ReducedLink.

The stage chain of DESIGN §2 as one pure function of a plain
:class:`LinkRequest` (no YAML here; see ``pipeline.workflow.link_build``).
Every result is re-expressed in the body frame = the reference interface's
frame, where the modes are clamped.
"""

from __future__ import annotations

import logging
import sys
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.progress import StageTimes, stage
from pipeline.fem.interfaces import Interface, InterfaceSpec, make_interface, resolve_interfaces
from pipeline.fem.model import FemModel
from pipeline.fem.moments import MassMoments, mass_moments
from pipeline.fem.rigid_fit import warn_if_far
from pipeline.fem.stress import RESULTANTS, VOIGT, stress_modes, tensor_to_voigt, voigt_to_tensor
from pipeline.invariants.adequacy import DIRECTIONS
from pipeline.invariants.body_frame import congruent, inverse_pose, points_to_body, vectors_to_body
from pipeline.invariants.participation import align_repeated
from pipeline.invariants.reduced_link import FrameModes, ReducedLink
from pipeline.meshing.budget import MeshBudget
from pipeline.meshing.geometry import BeamGeometry, SolidGeometry
from pipeline.meshing.imported import MeshFileGeometry
from pipeline.meshing.mesh_data import MeshData
from pipeline.modes.basis import ModalBasis

logger = logging.getLogger(__name__)

#: Poisson's ratio above which a solid link is warned of volumetric locking
NEARLY_INCOMPRESSIBLE = 0.49


@dataclass(frozen=True)
class MarkerRequest:
    """A named frame whose modal motion is reported (force point, sensor).

    position (3,) m and axes (3, 3) in the link frame; its motion is the
    least-squares rigid fit over the FE nodes within ``radius`` m (default:
    the nearest 12 nodes; beams: the nearest node with a rigid offset).
    """

    name: str
    position: np.ndarray
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))
    radius: float | None = None


@dataclass(frozen=True)
class LinkRequest:
    """Everything needed to reduce one link (plain values, SI units).

    ``sections`` (beams) holds one BeamSection per polyline member; ``materials`` the
    materials of a mesh's element sets (cells in none have ``material``); ``mesh_budget``
    what a solid's meshing may take (default: :class:`MeshBudget`'s).
    """

    name: str
    geometry: SolidGeometry | BeamGeometry | MeshFileGeometry
    material: Any  # pipeline.fem.Material
    interfaces: tuple[InterfaceSpec, ...]
    reference: str
    sections: tuple = ()
    materials: tuple = ()  # (element-set name, Material) of a link of several materials
    markers: tuple[MarkerRequest, ...] = ()
    point_masses: tuple = ()
    n_modes: int | None = None
    f_max: float | None = None
    craig_bampton: bool = False
    geometric_stiffening: bool = False
    chord: str | None = None
    mesh_budget: MeshBudget | None = None
    modes_file: Path | None = None  # clamped modes computed by another FE code (.frd)


def reduce_link(request: LinkRequest, times: StageTimes | None = None,
                meta: dict | None = None) -> ReducedLink:
    """Mesh, assemble, tie, compute modes and invariants of one link.

    Parameters
    ----------
    request : LinkRequest
    times : StageTimes, optional; receives seconds per stage.
    meta : extra provenance stored in the artifact (input hash, settings).

    Returns
    -------
    ReducedLink in the body frame of ``request.reference``.
    """
    from pipeline.meshing import build_mesh
    from pipeline.modes import clamped_modes, frame_motion

    times = times if times is not None else StageTimes()
    name = request.name
    with stage(f"meshing link '{name}'", times):
        mesh = build_mesh(request.geometry, name, budget=request.mesh_budget)
    with stage(f"assembling K, M of link '{name}'", times):
        model = _assemble(request, mesh)
    if isinstance(request.geometry, MeshFileGeometry):
        _check_imported(request, mesh, model)
    with stage(f"tying interfaces of link '{name}'", times):
        from pipeline.fem.interfaces import tie_interfaces

        interfaces = resolve_interfaces(model, request.interfaces, mesh.groups)
        tied = tie_interfaces(model, interfaces)
    with stage(f"eigen solve of link '{name}'", times):
        from pipeline.modes.clamp import ClampedProblem

        problem = ClampedProblem(tied, request.reference, request.chord)
        file_stress = None
        if request.modes_file is None:
            basis = clamped_modes(tied, request.reference, n_modes=request.n_modes,
                                  f_max=request.f_max, craig_bampton=request.craig_bampton,
                                  problem=problem)
        else:
            basis, file_stress = _external_modes(request, mesh, model, tied, problem)
    with stage(f"invariants of link '{name}'", times):
        moments = mass_moments(model, basis.shapes)
        markers = tuple(_marker_interface(model, m) for m in request.markers)
        motions = [(itf, *frame_motion(model, tied, basis, itf)) for itf in
                   _reference_first(interfaces, request.reference) + markers]
    ref = tied.interface(request.reference)
    with stage(f"interface compliance of link '{name}'", times):
        from pipeline.modes.compliance import interface_statics

        loaded = [m[0] for m in motions[1:]]  # every frame but the reference
        C, g, c = interface_statics(model, tied, problem, loaded, ref.pose[:3, :3])
        compliance = {"frames": [f.name for f in loaded], "directions": list(DIRECTIONS),
                      "units": "m/N, rad/N, m/(N m), rad/(N m); body axes",
                      "matrix": C.tolist(),
                      "body_load": {"frames": g.tolist(), "work": c.tolist(),
                                    "units": "per unit acceleration along the body axes: "
                                             "frames m, rad per m/s^2; work N m per "
                                             "(m/s^2)^2"}}
    KG, KF, KI, stiffening = None, None, None, {}
    if request.geometric_stiffening:
        from pipeline.fem.geometric import CENTRIFUGAL_CASES, INERTIA_CASES
        from pipeline.invariants.stiffening import (
            centrifugal_from_inertia,
            frame_force_stiffness,
            inertia_stiffness,
        )

        with stage(f"geometric stiffness of link '{name}'", times):
            KI = inertia_stiffness(model, tied, basis, ref.pose, problem)
            KG = centrifugal_from_inertia(KI)
            KF = frame_force_stiffness(model, tied, basis, ref.pose,
                                       [m[0] for m in motions], problem)
        stiffening = {"geometric_stiffening": {
            "cases": list(CENTRIFUGAL_CASES), "inertia_cases": list(INERTIA_CASES),
            "frame_forces": [m[0].name for m in motions]}}
    info = {"n_dof": model.n_dof, "n_nodes": model.n_nodes, "units": "SI (m, kg, s, N, rad)",
            "stage_seconds": times.as_dict(), "mesh": _mesh_quality(mesh, moments, request),
            "reference_conditions": {"reference": request.reference, "chord": request.chord,
                                     "craig_bampton": basis.settings.get("cb_interfaces", [])},
            "interface_compliance": compliance,
            "interface_nodes": _interface_nodes(request, interfaces), **stiffening,
            **(meta or {})}
    cells = model.extras.get("cell_materials")
    if cells is not None and not cells.uniform:
        count = np.bincount(cells.index, minlength=len(cells.materials))
        info["materials"] = {name: {"E": m.E, "nu": m.nu, "rho": m.rho, "cells": int(k)}
                             for name, m, k in zip(cells.names, cells.materials, count,
                                                   strict=True)}
    S = None
    if "material" in model.extras or model.kind == "beam":
        with stage(f"stress modes of link '{name}'", times):
            S = _stress_to_body(model, ref.pose, stress_modes(model, basis.shapes))
    elif file_stress is not None:
        S = _stress_to_body(model, ref.pose, file_stress)
    info["stage_seconds"] = times.as_dict()  # with the stress modes
    info["factorisation"] = basis.settings.get("factorisation")
    if "external" in basis.settings:  # modes from another FE code: which, and how they fit
        info["modes_file"] = dict(basis.settings["external"])
    info["peak_memory_mib"] = peak_memory_mib()
    if S is None:
        info["stress"] = {"unavailable": "the link's K and M came from another FE code as "
                                         "matrices, without its element formulation: no "
                                         "stress modes"}
    elif file_stress is not None:
        info["stress"] = {"kind": "voigt", "components": list(VOIGT), "units": "Pa, body axes",
                          "recovery": f"the FE code's nodal stresses of its modes "
                                      f"({request.modes_file.name})"}
    elif model.kind == "beam":
        info["stress"] = {"kind": "resultants", "components": list(RESULTANTS),
                          "units": "N, N m, element axes"}
    else:
        info["stress"] = {"kind": "voigt", "components": list(VOIGT), "units": "Pa, body axes",
                          "recovery": "P2 element stress at its nodes, mean over the elements"}
    link = _to_body_frame(name, model, mesh, basis, moments, motions, markers, ref, info)
    link = replace(link, stress_modes=S)
    if KG is not None:
        link = replace(link, geometric_stiffness=KG, force_geometric_stiffness=KF,
                       inertia_geometric_stiffness=KI)
    # repeated frequencies (symmetric sections): modes along the body axes, not mixtures
    return align_repeated(link)


def _external_modes(request: LinkRequest, mesh: MeshData, model: FemModel, tied,
                    problem) -> tuple[ModalBasis, np.ndarray | None]:
    """The basis of the modes another FE code computed (``request.modes_file``), and, for a
    link imported as matrices, the code's stress modes (m, n_nodes, 6), Pa, link axes."""
    from pipeline.fem.imported import input_node_points
    from pipeline.meshing.imported import MASS_UNITS
    from pipeline.modes.external import external_basis, mode_stresses, read_frd

    g = request.geometry
    where = f"link '{request.name}': modes.file"
    try:
        modes = read_frd(request.modes_file)
    except ConfigError as exc:  # named at the spec's modes.file
        raise ConfigError(f"{where}: {exc}") from None
    node_of_id = input_node_points(g.path, mesh, g.scale, where)
    basis, W = external_basis(model, tied, request.reference, problem.K, problem.M,
                              problem.space.keep, modes, node_of_id, g.scale,
                              request.n_modes, request.f_max)
    if g.matrices is None or modes.stresses is None:
        return basis, None
    unit = MASS_UNITS[g.matrices.mass_unit] / g.scale  # Pa per the file's stress unit
    return basis, mode_stresses(modes, node_of_id, model.n_nodes, W, unit)


def peak_memory_mib() -> float | None:
    """This process's peak resident memory so far, MiB (what ran before in the same
    process included); None where the platform does not tell."""
    try:
        import resource
    except ImportError:  # Windows
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return round(peak / (2**20 if sys.platform == "darwin" else 2**10), 1)  # bytes / KiB


def _assemble(request: LinkRequest, mesh: MeshData) -> FemModel:
    from pipeline.fem import add_point_masses, assemble_solid
    from pipeline.fem.material import check_material

    where = f"link '{request.name}'"
    check_material(request.material, where)
    g = request.geometry
    if isinstance(g, MeshFileGeometry) and g.matrices is not None:
        from pipeline.fem.imported import read_matrices

        if request.geometric_stiffening:
            raise ConfigError(f"{where}: modes.geometric_stiffening: needs the element "
                              "formulation, which a link imported as matrices does not carry: "
                              "leave it off (or import the mesh alone and assemble it here)")
        model = read_matrices(g.matrices, mesh, g.scale, request.name)
    elif mesh.kind == "solid":
        for key, mat in (("material", request.material),
                         *((f"materials.{n}", m) for n, m in request.materials)):
            if mat.nu > NEARLY_INCOMPRESSIBLE:
                logger.warning(
                    "%s: %s.nu = %g is nearly incompressible: displacement-based P2 "
                    "tetrahedra lock volumetrically as nu -> 0.5 (deflections and frequencies "
                    "come out stiff), and the bulk stiffness swamps the round-off scale of the "
                    "mode checks; there is no mixed (u-p) formulation here: use nu <= %g",
                    where, key, mat.nu, NEARLY_INCOMPRESSIBLE)
        model = assemble_solid(mesh, request.material, request.name, dict(request.materials))
    else:
        from pipeline.fem.beam import assemble_beam, sections_by_member

        n_members = len(request.geometry.points) - 1
        if len(request.sections) != n_members:
            raise ConfigError(f"{where}: sections: expected one section per member "
                              f"({n_members}), got {len(request.sections)}")
        model = assemble_beam(mesh, sections_by_member(mesh, request.sections, request.name),
                              request.name)
    if request.point_masses:
        model = add_point_masses(model, request.point_masses, where)
    return model


#: the largest link this tool expects, m across (a mesh in mm read as m is 1000x that of
#: its machine: a 5 m boom becomes 5 km)
MAX_LINK_SIZE = 300.0


def _check_imported(request: LinkRequest, mesh: MeshData, model) -> None:
    """A mesh file read in the wrong unit, caught by the link's size, the spec's positions
    (m) and its expected mass (:func:`pipeline.meshing.imported.check_units`)."""
    from pipeline.meshing.imported import check_units

    g = request.geometry
    where = f"link '{request.name}'"
    size = float(np.linalg.norm(np.ptp(mesh.points, axis=0)))
    if size > MAX_LINK_SIZE:
        raise ConfigError(f"{where}: the mesh read in geometry.units {g.units!r} is {size:.4g} m "
                          f"across, more than a machine's link ({MAX_LINK_SIZE:g} m): is the "
                          "file in mm?")
    ux = np.zeros(model.n_dof)
    ux[model.node_dofs[:, 0]] = 1.0
    mass = float(ux @ (model.mass @ ux))
    positions = {f"interface '{i.name}' origin": i.origin for i in request.interfaces}
    positions.update({f"marker '{m.name}'": m.position for m in request.markers})
    check_units(mesh, positions, g.units, where, g.expected_mass, mass)
    if g.matrices is not None:
        _check_matrix_mass(request, mesh, mass, where)
    logger.info("link '%s': imported mesh %s: %d nodes, %.4g m across, %.6g kg", request.name,
                g.path.name, mesh.n_points, size, mass)


def _check_matrix_mass(request: LinkRequest, mesh: MeshData, mass: float, where: str) -> None:
    """The mass of imported matrices against material.rho times the mesh's volume: a wrong
    geometry.matrices.mass_unit scales K and M alike, so the frequencies come out right
    while every inertia and weight of the machine is 1000 times off."""
    from pipeline.meshing.mesh_data import tet_signed_volumes

    cells = next(iter(mesh.cells.values()))
    expected = request.material.rho * float(np.abs(tet_signed_volumes(mesh.points, cells)).sum())
    if abs(mass - expected) > 0.05 * expected:
        g = request.geometry
        raise ConfigError(
            f"{where}: the matrices' mass {mass:.6g} kg (geometry.matrices.mass_unit "
            f"{g.matrices.mass_unit!r}) is {mass / expected:.4g} times material.rho x the "
            f"mesh's volume ({expected:.6g} kg): is the mass unit right (t with mm and N), "
            "and material.rho the FE model's?")


def _interface_nodes(request, interfaces) -> list[dict]:
    """Each interface's FE nodes (indices into the link's ``nodes``) and the mesh group its
    selector named, if any: an exported mesh carries them as node sets
    (:mod:`pipeline.invariants.mesh_export`), so the same spec reads it back."""
    from pipeline.meshing.selectors import PhysicalGroup

    selectors = {s.name: s.selector for s in request.interfaces}
    out = []
    for itf in interfaces:
        sel = selectors.get(itf.name)
        out.append({"interface": itf.name,
                    "group": sel.name if isinstance(sel, PhysicalGroup) else None,
                    "nodes": [int(k) for k in itf.nodes]})
    return out


def _reference_first(interfaces, reference: str) -> tuple[Interface, ...]:
    return tuple(sorted(interfaces, key=lambda i: i.name != reference))


def _marker_interface(model: FemModel, marker: MarkerRequest) -> Interface:
    """The marker as an averaging interface over nearby nodes (or one beam node)."""
    where = f"link {model.name!r}: marker {marker.name!r}"
    position = [float(x) for x in marker.position]
    d = np.linalg.norm(model.nodes - np.asarray(marker.position), axis=1)
    warn_if_far(model.nodes, d, position, where)
    if model.has_rotations:
        nodes = np.array([int(np.argmin(d))])
    elif marker.radius is not None:
        nodes = np.flatnonzero(d <= marker.radius)
        if nodes.size == 0:
            raise ConfigError(f"{where}: no FE node within its radius {marker.radius:g} m of "
                              f"{position}; the nearest is {d.min():.3g} m away")
    else:  # the 12 nearest, and every node as near as the 12th: a tie (a symmetric mesh)
        # is not broken by round-off (a mesh written to 13 digits picked other nodes)
        near = np.sort(d)[min(11, d.size - 1)]
        nodes = np.flatnonzero(d <= near + 1e-9 * max(near, 1e-12))
    return make_interface(model, marker.name, marker.position, marker.axes, "rbe3", nodes)


def _mesh_quality(mesh: MeshData, moments: MassMoments, request: LinkRequest) -> dict:
    """Geometric discretisation error: FE mass properties vs the CAD solid's."""
    if "volume" not in mesh.cad or request.point_masses or request.materials:
        return {}
    rho = request.material.rho
    C = moments.C
    m_cad = rho * float(mesh.cad["volume"])
    S_cad = rho * np.asarray(mesh.cad["second_moment"])
    c_cad = np.asarray(mesh.cad["centroid"])
    size = np.sqrt(np.trace(S_cad) / m_cad)
    return {
        "cad_mass_kg": m_cad,
        "mass_rel_error": abs(C[3, 3] - m_cad) / m_cad,
        "com_error_m": float(np.linalg.norm(C[:3, 3] / C[3, 3] - c_cad)),
        "second_moment_rel_error": float(np.abs(C[:3, :3] - S_cad).max()
                                         / (m_cad * size**2)),
    }


def _stress_to_body(model: FemModel, H: np.ndarray, S: np.ndarray) -> np.ndarray:
    """(m, N, 6) float32: solid stresses rotated to the body axes (R^T sigma R); beam
    resultants stay in their element axes."""
    if model.kind == "beam":
        return S.astype(np.float32)
    R = H[:3, :3]
    # R^T sigma R is linear in the Voigt vector: one 6 x 6 matrix, its columns the images
    # of the unit Voigt vectors (not a 3 x 3 product per node and mode)
    units = np.einsum("ai,lab,bj->lij", R, voigt_to_tensor(np.eye(6)), R)
    return (S @ tensor_to_voigt(units)).astype(np.float32)


def _to_body_frame(name, model, mesh, basis, moments, motions, markers, ref, info) -> ReducedLink:
    H = ref.pose
    Hi = inverse_pose(H)
    frames = []
    for itf, phi, psi in motions:
        kind = "marker" if any(itf is m for m in markers) else "interface"
        frames.append(FrameModes(itf.name, Hi @ itf.pose, vectors_to_body(H, phi),
                                 vectors_to_body(H, psi), kind))
    shapes = basis.shapes[model.node_dofs[:, :3]]  # (N, 3, m)
    cells = model.extras.get("cells", next(iter(mesh.cells.values())))
    surface = next(iter(mesh.boundary.values()), np.zeros((0, 3), int))
    K, Mm = basis.modal_stiffness, basis.modal_mass
    return ReducedLink(
        name=name, kind=model.kind, body_pose=H,
        C=congruent(Hi, moments.C), Cp=congruent(Hi, moments.Cp), Cpp=congruent(Hi, moments.Cpp),
        modal_stiffness=0.5 * (K + K.T), modal_mass=0.5 * (Mm + Mm.T),
        frequencies_hz=np.asarray(basis.frequencies_hz), mode_kinds=tuple(basis.kinds),
        frames=tuple(frames), nodes=points_to_body(H, model.nodes),
        cells=np.asarray(cells), surface=np.asarray(surface),
        mode_shapes=vectors_to_body(H, np.moveaxis(shapes, 2, 0)), meta=info,
    )
