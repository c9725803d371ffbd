"""Meshes from other FE tools (issue 28 item 1): read with meshio, reduced as a native mesh,
checked against CalculiX run on the very same mesh.

The mesh is a cantilever box 400 x 20 x 10 mm in 384 quadratic tetrahedra, built by hand
(:mod:`box_mesh`), written in millimetres as Abaqus ``.inp`` and Nastran ``.bdf`` by meshio.
CalculiX (Debian's ``calculix-ccx``; the test skips where it is absent) computes its clamped
frequencies from its own C3D10 elements; the pipeline's clamped modes of the imported file
must give the same numbers.
"""

from __future__ import annotations

import re
import shutil
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from calculix_box import GROUPS, NU, PLANES, RHO, E, L, make_box
from calculix_box import calculix_deck as _calculix_deck
from calculix_box import calculix_frequencies as _calculix_frequencies
from calculix_box import run_calculix as _run_calculix
from calculix_box import write_spec as _spec

from pipeline.core.errors import ConfigError, MeshError
from pipeline.meshing.imported import MeshFileGeometry, read_mesh


@pytest.fixture(scope="module")
def box():
    return make_box()


def _write(path: Path, box, fmt: str, extra_cells=()) -> Path:
    pts, tets, pivot, tip = box
    cells = [("tetra10", tets), *extra_cells]
    sets = {"pivot": pivot, "tip": tip} if fmt == "abaqus" else {}
    meshio.write(path, meshio.Mesh(pts, cells, point_sets=sets), file_format=fmt)
    return path


def test_abaqus_file_is_read_in_metres_with_its_sets(tmp_path, box):
    pts, tets, pivot, tip = box
    # a beam to a reference node and a shell face beside the solid: left out of it
    extra = [("line", np.array([[0, len(pts)]])), ("triangle", tets[:1, :3])]
    pts_x = np.vstack([pts, [[999.0, 0.0, 0.0]]])
    path = tmp_path / "box.inp"
    meshio.write(path, meshio.Mesh(pts_x, [("tetra10", tets), *extra],
                                   point_sets={"pivot": pivot, "tip": tip}))
    mesh = read_mesh(MeshFileGeometry(path, "mm"), "box")
    assert mesh.kind == "solid" and mesh.order == 2 and mesh.n_points == len(pts)
    assert np.allclose(mesh.points.max(axis=0), [0.4, 0.02, 0.01], rtol=1e-14)
    assert set(mesh.groups) == {"pivot", "tip"}
    assert np.allclose(mesh.points[mesh.groups["pivot"], 0], 0.0)
    assert np.allclose(mesh.points[mesh.groups["tip"], 0], 0.4)
    assert len(mesh.groups["pivot"]) == len(pivot)
    # closed outward surface: the boundary's divergence-theorem volume is the box's
    tri = mesh.boundary["triangle6"][:, :3]
    p = mesh.points
    vol = np.einsum("ij,ij->i", p[tri[:, 0]], np.cross(p[tri[:, 1]], p[tri[:, 2]])).sum() / 6
    assert vol == pytest.approx(0.4 * 0.02 * 0.01, rel=1e-12)
    # 2 (faces) x (16 x 2 + 16 x 2 + 2 x 2) bricks' faces, each split in two
    assert len(tri) == 2 * 2 * (32 + 32 + 4)


def test_refusals_name_the_remedy(tmp_path):
    hexa = tmp_path / "hex.inp"
    meshio.write(hexa, meshio.Mesh(np.eye(8, 3), [("hexahedron", np.arange(8)[None])]))
    with pytest.raises(MeshError, match="hexahedron.*takes tetrahedra"):
        read_mesh(MeshFileGeometry(hexa, "m"), "h")
    with pytest.raises(MeshError, match="no such file"):
        read_mesh(MeshFileGeometry(tmp_path / "none.inp", "m"), "h")
    junk = tmp_path / "junk.bdf"
    junk.write_text("CTETRA,1,1,2,3\nGRID*,garbage\n")
    with pytest.raises(MeshError, match="meshio could not read it"):
        read_mesh(MeshFileGeometry(junk, "m"), "j")
    with pytest.raises(ConfigError, match="geometry.units"):
        MeshFileGeometry("a.inp", "furlong")
    with pytest.raises(ConfigError, match="suffixes"):
        MeshFileGeometry("a.stl", "m")


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (apt calculix-ccx) absent")
@pytest.mark.parametrize("fmt, suffix, interfaces", [("abaqus", "inp", GROUPS),
                                                     ("nastran", "bdf", PLANES)])
def test_imported_link_has_calculix_frequencies(tmp_path, box, fmt, suffix, interfaces):
    """The clamped modes of the imported mesh (assembled here) against CalculiX's on the same
    mesh, the tip an averaging (rbe3) interface that adds no stiffness. Measured: the first
    two within 2.4e-7, the first six within 2.2e-5 (the difference grows with the mode's
    order, as from the two codes' element integration; with CalculiX's own matrices the
    next test agrees to 6e-7); bounded at 3e-5."""
    from pipeline.workflow.link_build import reduce_spec

    _write(tmp_path / f"box.{suffix}", box, fmt)
    spec = _spec(tmp_path, f"box.{suffix}", "mm", interfaces)
    link, _ = reduce_spec(spec, tmp_path, tmp_path / "out")
    ref = _calculix_frequencies(tmp_path, box)
    ours = np.asarray(link.frequencies_hz)[:6]
    assert 52.0 < ref[0] < 53.0  # Euler-Bernoulli: 52.2 Hz
    assert np.allclose(ours[:2], ref[:2], rtol=1e-6), (ours, ref)
    assert np.allclose(ours, ref, rtol=3e-5), (ours, ref)
    assert link.mass == pytest.approx(RHO * 0.4 * 0.02 * 0.01, rel=1e-12)


#: the far part of the two-material box: aluminium beyond x = 150 mm
E2, NU2, RHO2, X_JOINT = 7.0e10, 0.33, 2700.0, 150.0
TWO = "materials: {FAR: {E: 7.0e10, nu: 0.33, rho: 2700.0}}"


def _two_parts(box):
    """(near, far) cell indices of the box, split at x = X_JOINT (an element boundary)."""
    pts, tets, _, _ = box
    x = pts[tets[:, :4]].mean(axis=1)[:, 0]
    return np.flatnonzero(x < X_JOINT), np.flatnonzero(x > X_JOINT)


def test_element_sets_and_property_ids_become_cell_groups(tmp_path, box):
    pts, tets, pivot, _ = box
    near, far = _two_parts(box)
    inp = tmp_path / "two.inp"
    meshio.write(inp, meshio.Mesh(pts, [("tetra10", tets)], point_sets={"pivot": pivot},
                                  cell_sets={"NEAR": [near], "FAR": [far]}))
    mesh = read_mesh(MeshFileGeometry(inp, "mm"), "box")
    assert set(mesh.cell_groups) == {"NEAR", "FAR"}
    assert np.array_equal(mesh.cell_groups["FAR"], far)
    assert np.all(mesh.points[mesh.cells["tetra10"][mesh.cell_groups["FAR"]][:, :4], 0]
                  >= X_JOINT * 1e-3 - 1e-12)
    bdf = tmp_path / "two.bdf"
    pid = np.where(np.isin(np.arange(len(tets)), far), 2, 1)
    meshio.write(bdf, meshio.Mesh(pts, [("tetra10", tets)], cell_data={"nastran:ref": [pid]}))
    mesh = read_mesh(MeshFileGeometry(bdf, "mm"), "box")
    assert set(mesh.cell_groups) == {"PID1", "PID2"}
    assert np.array_equal(mesh.cell_groups["PID2"], far)
    # gmsh: physical volumes name cell groups (a physical surface names nodes only)
    msh = tmp_path / "two.msh"
    phys = np.where(np.isin(np.arange(len(tets)), far), 2, 1)
    face = tets[:2, [0, 1, 2, 4, 5, 6]]
    meshio.write(msh, meshio.Mesh(pts, [("tetra10", tets), ("triangle6", face)],
                                  cell_data={"gmsh:physical": [phys, np.array([3, 3])],
                                             "gmsh:geometrical": [phys, np.array([3, 3])]},
                                  field_data={"NEAR": np.array([1, 3]), "FAR": np.array([2, 3]),
                                              "FACE": np.array([3, 2])}),
                 file_format="gmsh22", binary=False)
    mesh = read_mesh(MeshFileGeometry(msh, "mm"), "box")
    assert set(mesh.cell_groups) == {"NEAR", "FAR"} and "FACE" in mesh.groups
    assert np.array_equal(mesh.cell_groups["FAR"], far)


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (apt calculix-ccx) absent")
def test_a_link_of_two_materials_has_calculix_frequencies(tmp_path, box):
    """Steel to x = 150 mm, aluminium beyond, by element set: the imported link's clamped
    frequencies against CalculiX's model with a *SOLID SECTION per set (same bounds as
    the one-material box above); the mass is the two parts' by closed form."""
    from pipeline.workflow.link_build import reduce_spec

    pts, tets, pivot, tip = box
    near, far = _two_parts(box)
    meshio.write(tmp_path / "two.inp",
                 meshio.Mesh(pts, [("tetra10", tets)], point_sets={"pivot": pivot, "tip": tip},
                             cell_sets={"NEAR": [near], "FAR": [far]}))
    spec = _spec(tmp_path, "two.inp", "mm", GROUPS, materials=TWO)
    link, _ = reduce_spec(spec, tmp_path, tmp_path / "out")
    ref = _calculix_frequencies(tmp_path, box, parts={"NEAR": (near, E, NU, RHO),
                                                      "FAR": (far, E2, NU2, RHO2)})
    ours = np.asarray(link.frequencies_hz)[:6]
    (tmp_path / "one").mkdir()
    steel_only = _calculix_frequencies(tmp_path / "one", box)
    print("two materials, Hz: ours", ours, "CalculiX", ref, "steel alone", steel_only)
    assert abs(ref[0] / steel_only[0] - 1) > 0.05  # the second material matters
    assert np.allclose(ours[:2], ref[:2], rtol=1e-6), (ours, ref)
    assert np.allclose(ours, ref, rtol=3e-5), (ours, ref)
    volume = 0.4 * 0.02 * 0.01
    assert link.mass == pytest.approx(volume * (RHO * 0.375 + RHO2 * 0.625), rel=1e-12)
    assert link.meta["materials"]["FAR"] == {"E": E2, "nu": NU2, "rho": RHO2,
                                             "cells": len(far)}
    # the Nastran twin, its second part by property id: the same link
    pid = np.where(np.isin(np.arange(len(tets)), far), 2, 1)
    meshio.write(tmp_path / "two.bdf",
                 meshio.Mesh(pts, [("tetra10", tets)], cell_data={"nastran:ref": [pid]}))
    spec = _spec(tmp_path, "two.bdf", "mm", PLANES, materials=TWO.replace("FAR", "PID2"))
    twin, _ = reduce_spec(spec, tmp_path, tmp_path / "out")
    assert np.allclose(twin.frequencies_hz[:6], ours, rtol=1e-9)
    assert twin.mass == pytest.approx(link.mass, rel=1e-12)
    # the materials the files give: CalculiX's own deck (*MATERIAL, *SOLID SECTION; mm, t,
    # MPa), and the Nastran file with its MAT1 and PSOLID cards (steel in small field,
    # aluminium in free field): the same link again
    spec = _spec(tmp_path, "ccx/box.inp", "mm", PLANES, extra=", mass_unit: t",
                 materials="materials: file")
    deck, _ = reduce_spec(spec, tmp_path, tmp_path / "out")
    bdf = (tmp_path / "two.bdf").read_text().replace(
        "ENDDATA", "MAT1    1       210000.         .3      7.85-9\n"
                   "MAT1,2,7.+4,,.33,2.7-9\nPSOLID  1       1\nPSOLID,2,2\nENDDATA")
    (tmp_path / "cards.bdf").write_text(bdf)
    spec = _spec(tmp_path, "cards.bdf", "mm", PLANES, extra=", mass_unit: t",
                 materials="materials: file")
    cards, _ = reduce_spec(spec, tmp_path, tmp_path / "out")
    for other in (deck, cards):
        assert np.allclose(other.frequencies_hz[:6], ours, rtol=1e-9)
        assert other.mass == pytest.approx(link.mass, rel=1e-12)


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (apt calculix-ccx) absent")
def test_a_link_of_two_materials_deflects_as_in_calculix(tmp_path, box):
    """The two-material box clamped at x = 0 with 10 N on each tip node along y: the
    imported file's stiffness (assembled here, materials from the file) against CalculiX's
    static solution on the same deck; the mean tip deflection within 1e-6."""
    import scipy.sparse.linalg as spla

    from pipeline.fem import Material, assemble_solid
    from pipeline.meshing.file_materials import read_file_materials

    _, _, pivot, tip = box
    near, far = _two_parts(box)
    deck = _calculix_deck(box, parts={"NEAR": (near, E, NU, RHO), "FAR": (far, E2, NU2, RHO2)})
    head = deck[:deck.index("*STEP")]
    deck = head + "\n".join(
        ["*NSET, NSET=TIP"] + [", ".join(str(k + 1) for k in tip[i:i + 8])
                               for i in range(0, len(tip), 8)]
        + ["*STEP", "*STATIC", "*BOUNDARY", "FIX, 1, 3", "*CLOAD", "TIP, 2, 10.",
           "*NODE PRINT, NSET=TIP", "U", "*END STEP"]) + "\n"
    dat = _run_calculix(tmp_path / "ccx", deck, "static")
    rows = re.findall(r"^\s+(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$",
                      dat.split("displacements")[1], re.MULTILINE)
    ccx_uy = np.mean([float(r[2]) for r in rows]) * 1e-3  # mm -> m
    assert len(rows) == len(tip)

    path = tmp_path / "ccx" / "static.inp"
    mesh = read_mesh(MeshFileGeometry(path, "mm"), "box")
    mats = {k: Material(*v) for k, v in read_file_materials(path, "abaqus", 1e-3, 1e3).items()}
    model = assemble_solid(mesh, Material(E, NU, RHO), "box", mats)
    fixed = model.node_dofs[pivot].ravel()
    free = np.setdiff1d(np.arange(model.n_dof), fixed)
    f = np.zeros(model.n_dof)
    f[model.node_dofs[tip, 1]] = 10.0
    K = model.stiffness.tocsr()
    u = np.zeros(model.n_dof)
    u[free] = spla.spsolve(K[free][:, free].tocsc(), f[free])
    ours = u[model.node_dofs[tip, 1]].mean()
    assert 1e-4 < abs(ccx_uy) < 1e-2
    print(f"tip deflection: ours {ours:.10e} m, CalculiX {ccx_uy:.10e} m")
    assert ours == pytest.approx(ccx_uy, rel=1e-6)


def test_materials_are_refused_where_they_cannot_apply(tmp_path, box):
    from pipeline.workflow.link_build import reduce_spec

    _write(tmp_path / "box.inp", box, "abaqus")
    spec = _spec(tmp_path, "box.inp", "mm", GROUPS, materials=TWO)
    with pytest.raises(ConfigError, match=r"materials\.FAR: the mesh has no element set 'FAR'"):
        reduce_spec(spec, tmp_path, tmp_path / "out")
    with pytest.raises(ConfigError, match=r"box\.yaml:\d+: materials: .*file in mm need "
                                          r"geometry\.mass_unit"):
        _spec(tmp_path, "box.inp", "mm", GROUPS, materials="materials: file")
    with pytest.raises(ConfigError, match=r"box\.yaml:\d+: materials: .*from Abaqus"):
        _spec(tmp_path, "box.vtu", "m", GROUPS, materials="materials: file")
    with pytest.raises(ConfigError, match=r"box\.inp: has no solid section"):
        reduce_spec(_spec(tmp_path, "box.inp", "mm", GROUPS, extra=", mass_unit: t",
                          materials="materials: file"), tmp_path, tmp_path / "out")
    with pytest.raises(ConfigError, match=r"box\.yaml:\d+: materials: .*need a mesh file"):
        from pipeline.workflow.link_spec import load_link_spec

        (tmp_path / "box.yaml").write_text(
            "name: box\ngeometry: {type: solid, recipe: bar, params: {length: 1, width: 0.1, "
            "height: 0.1}, mesh_size: 0.05}\nmaterial: {E: 2.1e11, nu: 0.3, rho: 7850}\n" + TWO +
            "\ninterfaces:\n" + PLANES.replace("0.4", "1.0") + "\nreference: pivot\n"
            "modes: {count: 4}\n")
        load_link_spec(tmp_path / "box.yaml")


def test_a_file_in_mm_read_as_m_is_caught(tmp_path, box):
    from pipeline.workflow.link_build import reduce_spec

    _write(tmp_path / "box.inp", box, "abaqus")
    with pytest.raises(ConfigError, match=r"400.6 m across.*is the file in mm"):
        reduce_spec(_spec(tmp_path, "box.inp", "m", GROUPS), tmp_path, tmp_path / "o1")
    # an expected mass off by the cube of the unit: named
    with pytest.raises(ConfigError, match=r"expected_mass.*is the file in 'cm'"):
        reduce_spec(_spec(tmp_path, "box.inp", "mm", GROUPS, ", expected_mass: 628.0"),
                    tmp_path, tmp_path / "o2")
    # positions in m outside a mesh read in a unit too small
    with pytest.raises(ConfigError, match=r"interface 'tip' origin .* lies outside the mesh"):
        reduce_spec(_spec(tmp_path, "box.inp", "mm", GROUPS.replace("0.4, 0.01", "4.0, 0.01")),
                    tmp_path, tmp_path / "o3")


def test_gmsh_physical_groups_become_node_groups(tmp_path, box):
    """A .msh file's physical groups, here the tip face as quadratic triangles, name the
    nodes of their elements."""
    pts, tets, _, tip = box
    from pipeline.meshing.mesh_data import boundary_faces

    faces = boundary_faces(tets)
    at_tip = faces[np.all(pts[faces[:, :3], 0] == L, axis=1)]
    mesh = meshio.Mesh(pts, [("tetra10", tets), ("triangle6", at_tip)],
                       cell_data={"gmsh:physical": [np.full(len(tets), 1),
                                                    np.full(len(at_tip), 2)],
                                  "gmsh:geometrical": [np.full(len(tets), 1),
                                                       np.full(len(at_tip), 1)]},
                       field_data={"steel": np.array([1, 3]), "tip_face": np.array([2, 2])})
    path = tmp_path / "box.msh"
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    read = read_mesh(MeshFileGeometry(path, "mm"), "box")
    assert np.array_equal(np.sort(read.points[read.groups["tip_face"]], axis=0),
                          np.sort(pts[tip] * 1e-3, axis=0))
    assert len(read.groups["steel"]) == len(pts)


def _abaqus_mtx(sti: Path, dof: Path, out: Path) -> None:
    """CalculiX's upper-triangle matrix rewritten in Abaqus' coordinate .mtx form (node,
    dof, node, dof, value), lower triangle, as *MATRIX OUTPUT writes it."""
    rows = [tuple(map(int, d.split("."))) for d in dof.read_text().split()]
    data = np.loadtxt(sti, ndmin=2)
    with open(out, "w") as f:
        f.write("** written from CalculiX matrices for the test\n")
        for i, j, v in data:
            a, b = rows[int(j) - 1], rows[int(i) - 1]  # (col, row) of the upper: the lower
            f.write(f"{a[0]}, {a[1]}, {b[0]}, {b[1]}, {v:.17e}\n")


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (apt calculix-ccx) absent")
@pytest.mark.parametrize("form", ["calculix", "abaqus"])
def test_calculix_matrices_give_calculix_frequencies(tmp_path, box, form):
    """K and M assembled by CalculiX (free-free, mm and t), reduced here: the clamped
    frequencies are CalculiX's own from the same matrices, to its 7 printed digits (6e-7
    measured); the mass is rho V; no stress modes, and that is said."""
    from pipeline.workflow.link_build import reduce_spec

    work = tmp_path / "free"
    _run_calculix(work, _calculix_deck(box, clamped=False, storage=True), "model")
    if form == "calculix":
        extra = (", matrices: {format: calculix, stiffness: free/model.sti, mass: "
                 "free/model.mas, dofs: free/model.dof, mass_unit: t}")
    else:
        _abaqus_mtx(work / "model.sti", work / "model.dof", work / "model_STIF1.mtx")
        _abaqus_mtx(work / "model.mas", work / "model.dof", work / "model_MASS1.mtx")
        extra = (", matrices: {format: abaqus, stiffness: free/model_STIF1.mtx, mass: "
                 "free/model_MASS1.mtx, mass_unit: t}")
    spec = _spec(tmp_path, "free/model.inp", "mm", PLANES, extra)
    link, _ = reduce_spec(spec, tmp_path, tmp_path / "out")
    ref = _calculix_frequencies(tmp_path, box)
    ours = np.asarray(link.frequencies_hz)[:6]
    assert np.allclose(ours, ref, rtol=1e-6), (ours, ref)
    assert link.mass == pytest.approx(RHO * 0.4 * 0.02 * 0.01, rel=1e-9)
    assert link.stress_modes.size == 0 and "unavailable" in link.meta["stress"]


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (apt calculix-ccx) absent")
def test_matrices_of_another_mesh_or_a_clamped_model_are_refused(tmp_path, box):
    from pipeline.workflow.link_build import reduce_spec

    work = tmp_path / "clamped"
    _run_calculix(work, _calculix_deck(box, clamped=True, storage=True), "model")
    extra = (", matrices: {format: calculix, stiffness: clamped/model.sti, mass: "
             "clamped/model.mas, dofs: clamped/model.dof, mass_unit: t}")
    with pytest.raises(MeshError, match="mesh nodes have no rows.*free-free"):
        reduce_spec(_spec(tmp_path, "clamped/model.inp", "mm", GROUPS, extra), tmp_path,
                    tmp_path / "out")
    with pytest.raises(ConfigError, match="geometric_stiffening"):
        spec = _spec(tmp_path, "clamped/model.inp", "mm", GROUPS, extra)
        spec = spec.model_copy(update={"modes": spec.modes.model_copy(
            update={"geometric_stiffening": True})})
        reduce_spec(spec, tmp_path, tmp_path / "out2")


def test_an_imported_link_runs_in_a_workflow_with_stress_and_vtu(tmp_path, box):
    """Downstream of the import as of a native mesh: a pendulum of the imported box swings
    under gravity; its root stress series and the ParaView files come out."""
    from pipeline.workflow import run_workflow

    _write(tmp_path / "box.inp", box, "abaqus")
    (tmp_path / "box.yaml").write_text(f"""name: box
geometry: {{type: mesh, path: box.inp, units: mm}}
material: {{E: {E}, nu: {NU}, rho: {RHO}}}
interfaces:
  - {{name: pivot, selector: {{type: group, name: pivot}}, origin: [0, 0.01, 0.005]}}
  - {{name: tip, selector: {{type: group, name: tip}}, origin: [0.4, 0.01, 0.005], kind: rbe3}}
reference: pivot
markers:
  - {{name: near_root, position: [0.02, 0.01, 0.005]}}
modes: {{count: 4}}
""")
    (tmp_path / "swing.yaml").write_text("""name: swing
gravity: [0, -9.81, 0]
links:
  ground: {type: ground, frames: {O: {origin: [0, 0, 0]}}}
  arm: {type: flexible, spec: box.yaml, modes: 4}
joints:
  - {name: J, type: revolute, parent: ground.O, child: arm.pivot}
analyses:
  - {name: fall, type: dynamic, t_end: 0.1, outputs: 11}
outputs:
  plots:
    - {name: stress, analysis: fall, series: ["stress:arm.near_root:von_mises"]}
  exports: {csv: true, vtu: true}
""")
    res = run_workflow(tmp_path / "swing.yaml", out_root=tmp_path / "out",
                       cache_dir=tmp_path / "links", workers=1)
    assert res.manifest["status"] == "ok", res.manifest
    files = res.manifest["files"]
    assert "stress.png" in files and any(f.endswith(".pvd") for f in files)
    import csv

    with open(res.out_dir / "fall.csv") as f:
        rows = list(csv.DictReader(f))
    from scipy.integrate import solve_ivp

    theta = np.array([float(r["J.theta"]) for r in rows])
    # the rigid box pinned at its end's centre, released horizontal: theta'' = -g k cos theta,
    # k = (L / 2) / (L^2 / 3 + b^2 / 12) (b = 20 mm in the swing plane); measured 6.7e-5
    k = 0.2 / (0.4 ** 2 / 3 + 0.02 ** 2 / 12)
    ref = solve_ivp(lambda t, y: [y[1], -9.81 * k * np.cos(y[0])], (0, 0.1), [0, 0],
                    t_eval=np.linspace(0, 0.1, 11), rtol=1e-10, atol=1e-12).y[0]
    assert np.abs(theta - ref).max() < 2e-4 * np.abs(ref).max()


def test_a_matrix_file_of_one_triangle_or_both_reads_the_same():
    """CalculiX writes the upper triangle, Abaqus the lower or both; each reads as the same
    symmetric matrix (both triangles of a file were once completed again, doubling the
    off-diagonal entries)."""
    import scipy.sparse as sp

    from pipeline.fem.imported import _symmetric

    K = np.array([[4.0, -1.0, 0.5], [-1.0, 3.0, 0.0], [0.5, 0.0, 2.0]])
    for part in (np.triu(K), np.tril(K), K):
        np.testing.assert_array_equal(_symmetric(sp.csr_matrix(part)).toarray(), K)


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (apt calculix-ccx) absent")
def test_matrices_in_the_wrong_mass_unit_are_caught(tmp_path, box):
    """CalculiX's matrices in t read as kg: K and M scale alike, so the frequencies would be
    right and the link's mass 1000 times too small. Its mass against material.rho times the
    mesh's volume catches it, naming the mass unit."""
    from pipeline.workflow.link_build import reduce_spec

    _run_calculix(tmp_path / "free", _calculix_deck(box, clamped=False, storage=True), "model")
    extra = (", matrices: {format: calculix, stiffness: free/model.sti, mass: "
             "free/model.mas, dofs: free/model.dof, mass_unit: kg}")
    with pytest.raises(ConfigError, match=r"matrices.mass_unit 'kg'\) is 0.001 times"):
        reduce_spec(_spec(tmp_path, "free/model.inp", "mm", PLANES, extra), tmp_path,
                    tmp_path / "out")
