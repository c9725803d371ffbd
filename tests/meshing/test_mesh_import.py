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
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from box_mesh import box_tet10

from pipeline.core.errors import ConfigError, MeshError
from pipeline.meshing.imported import MeshFileGeometry, read_mesh

L, B, H = 400.0, 20.0, 10.0  # mm
E, NU, RHO = 2.1e11, 0.3, 7850.0


@pytest.fixture(scope="module")
def box():
    pts, tets = box_tet10(L, B, H, (16, 2, 2))
    pivot = np.flatnonzero(pts[:, 0] == 0.0)
    tip = np.flatnonzero(pts[:, 0] == L)
    return pts, tets, pivot, tip


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


def _spec(tmp_path: Path, mesh_file: str, units: str, interfaces: str, extra: str = ""):
    from pipeline.workflow.link_spec import load_link_spec

    text = f"""name: box
geometry: {{type: mesh, path: {mesh_file}, units: {units}{extra}}}
material: {{E: {E}, nu: {NU}, rho: {RHO}}}
interfaces:
{interfaces}
reference: pivot
modes: {{count: 6}}
"""
    p = tmp_path / "box.yaml"
    p.write_text(text)
    return load_link_spec(p)


GROUPS = """  - {name: pivot, selector: {type: group, name: pivot}, origin: [0, 0.01, 0.005]}
  - {name: tip, selector: {type: group, name: tip}, origin: [0.4, 0.01, 0.005]}"""
PLANES = """  - {name: pivot, selector: {type: plane, point: [0, 0.01, 0.005], normal: [1, 0, 0]}}
  - {name: tip, selector: {type: plane, point: [0.4, 0.01, 0.005], normal: [1, 0, 0]}}"""


def _calculix_frequencies(tmp_path: Path, box, n: int = 6) -> np.ndarray:
    """Clamped frequencies, Hz, of CalculiX's C3D10 model of the same mesh (mm, t, s)."""
    pts, tets, pivot, _ = box
    rows = ["*NODE, NSET=NALL"] + [f"{i + 1}, {p[0]:.12g}, {p[1]:.12g}, {p[2]:.12g}"
                                   for i, p in enumerate(pts)]
    rows += ["*ELEMENT, TYPE=C3D10, ELSET=EALL"] + [
        f"{e + 1}, " + ", ".join(str(k + 1) for k in t) for e, t in enumerate(tets)]
    rows += ["*NSET, NSET=FIX"] + [", ".join(str(k + 1) for k in pivot[i:i + 8])
                                   for i in range(0, len(pivot), 8)]
    # CalculiX reads 20 characters a field: 7.849999999999999e-09 would be 7.85
    rows += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{E * 1e-6:.12g}, {NU:.12g}", "*DENSITY",
             f"{RHO * 1e-12:.12g}", "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL", "*STEP",
             "*FREQUENCY", str(n), "*BOUNDARY", "FIX, 1, 3", "*END STEP"]
    work = tmp_path / "ccx"
    work.mkdir()
    (work / "box.inp").write_text("\n".join(rows) + "\n")
    run = subprocess.run(["ccx", "-i", "box"], cwd=work, capture_output=True, text=True,
                         timeout=300, check=False)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    dat = (work / "box.dat").read_text()
    table = dat.split("E I G E N V A L U E   O U T P U T")[1]
    rows = re.findall(r"^\s+(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$", table, re.MULTILINE)
    return np.array([float(r[3]) for r in rows[:n]])


@pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (apt calculix-ccx) absent")
@pytest.mark.parametrize("fmt, suffix, interfaces", [("abaqus", "inp", GROUPS),
                                                     ("nastran", "bdf", PLANES)])
def test_imported_link_has_calculix_frequencies(tmp_path, box, fmt, suffix, interfaces):
    """The clamped modes of the imported mesh against CalculiX on the same mesh. Measured:
    the first two agree to the 7 digits CalculiX prints, the sixth within 1.4e-5 (the
    difference grows with the mode's order, as a difference in the elements' mass
    integration would); bounded at 3e-5."""
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
