"""Solid recipes -> MeshData: valid meshes, node order, groups on the CAD surfaces."""

from pathlib import Path

import numpy as np
import pytest

from pipeline.meshing import SolidGeometry, build_mesh
from tests.meshing.conftest import TET10_EDGES, assert_valid_solid

pytestmark = pytest.mark.gmsh

PLATE = {"length": 0.2, "width": 0.05, "thickness": 0.01,
         "bores": [{"name": "A", "center": [0.03, 0.0], "radius": 0.01},
                   {"name": "B", "center": [0.17, 0.005], "radius": 0.008}]}
ARM = {"points": [[0, 0], [1.2, -0.25], [1.75, -0.8]], "point_names": ["pivot", "knee", "tip"],
       "width": 0.16, "knee_width": 0.22, "thickness": 0.02,
       "bores": [{"name": "pivot", "at": "pivot", "radius": 0.025},
                 {"name": "cyl", "at": "knee", "radius": 0.02},
                 {"name": "tip", "at": "tip", "radius": 0.02}]}
BOX = {"length": 0.5, "b": 0.06, "h": 0.08, "wall": 0.006,
       "cross_bores": [{"name": "p", "x": 0.04, "radius": 0.012, "axis": "y"},
                       {"name": "q", "x": 0.45, "radius": 0.01, "axis": "z", "offset": 0.005}]}

CASES = {
    "bar": (SolidGeometry("bar", {"L": 0.1, "b": 0.01, "h": 0.006}, 0.004, 2), {}),
    "plate": (SolidGeometry("plate_with_bores", PLATE, 0.006, 2),
              {"bore_A": ((0.03, 0, 0), (0, 0, 1), 0.01),
               "bore_B": ((0.17, 0.005, 0), (0, 0, 1), 0.008)}),
    "plate_p1_rounded": (SolidGeometry("plate_with_bores", {**PLATE, "corner_radius": 0.02},
                                       0.006, 1),
                         {"bore_A": ((0.03, 0, 0), (0, 0, 1), 0.01)}),
    "arm": (SolidGeometry("bent_plate", ARM, 0.03, 2),
            {"bore_pivot": ((0, 0, 0), (0, 0, 1), 0.025),
             "bore_cyl": ((1.2, -0.25, 0), (0, 0, 1), 0.02),
             "bore_tip": ((1.75, -0.8, 0), (0, 0, 1), 0.02)}),
    "box": (SolidGeometry("box_section", BOX, 0.012, 2),
            {"bore_p": ((0.04, 0, 0), (0, 1, 0), 0.012),
             "bore_q": ((0.45, 0.005, 0.0), (0, 0, 1), 0.01)}),
    "box_closed_p1": (SolidGeometry("box_section", {**BOX, "end_plates": True,
                                                    "end_plate_thickness": 0.01}, 0.012, 1),
                      {"bore_q": ((0.45, 0.005, 0.0), (0, 0, 1), 0.01)}),
}


@pytest.fixture(scope="module")
def meshes():
    return {k: build_mesh(g, k) for k, (g, _) in CASES.items()}


def _radial_distance(points, point, axis):
    rel = points - np.asarray(point)
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.linalg.norm(rel - np.outer(rel @ a, a), axis=1)


@pytest.mark.parametrize("case", CASES)
def test_recipe_gives_valid_mesh(meshes, case):
    mesh = meshes[case]
    vol = assert_valid_solid(mesh)
    assert mesh.kind == "solid" and mesh.points.dtype == float
    # straight tets approximate the CAD solid: within 1 % here, exact where no face is curved
    np.testing.assert_allclose(vol.sum(), float(mesh.cad["volume"]), rtol=1e-2)


@pytest.mark.parametrize("case", CASES)
def test_bore_groups_are_exactly_the_nodes_on_the_bore_surface(meshes, case):
    mesh = meshes[case]
    _, bores = CASES[case]
    for name, (point, axis, radius) in bores.items():
        d = _radial_distance(mesh.points, point, axis)
        # the bore axis line can meet other surfaces only away from the bore: restrict to the
        # bore's own neighbourhood along the axis (within the solid's through-thickness)
        on = np.flatnonzero(np.abs(d - radius) < 1e-9 * radius)
        np.testing.assert_array_equal(mesh.groups[name], on, err_msg=name)
        assert on.size >= 8


def test_tet10_edge_nodes_in_meshio_order_at_edge_midpoints(meshes):
    mesh = meshes["bar"]  # all faces flat: every edge is straight, its node is the midpoint
    tets, p = mesh.cells["tetra10"], mesh.points
    for i, (a, b) in enumerate(TET10_EDGES):
        np.testing.assert_allclose(p[tets[:, 4 + i]], (p[tets[:, a]] + p[tets[:, b]]) / 2,
                                   atol=1e-12)


def test_curved_p2_edge_nodes_lie_on_the_bore(meshes):
    mesh = meshes["plate"]
    tri = mesh.boundary["triangle6"]
    d = _radial_distance(mesh.points, (0.03, 0, 0), (0, 0, 1))
    on_bore = np.all(np.abs(d[tri[:, :3]] - 0.01) < 1e-9, axis=1)
    assert on_bore.sum() > 10
    # edge nodes of bore triangles are on the cylinder, not on the straight chord
    np.testing.assert_allclose(d[tri[on_bore, 3:]], 0.01, atol=1e-9)


def test_end_faces_of_bar_and_box(meshes):
    for case, L in (("bar", 0.1), ("box", 0.5), ("box_closed_p1", 0.5)):
        mesh = meshes[case]
        x = mesh.points[:, 0]
        np.testing.assert_array_equal(mesh.groups["end_x0"], np.flatnonzero(np.abs(x) < 1e-12))
        np.testing.assert_array_equal(mesh.groups["end_xL"],
                                      np.flatnonzero(np.abs(x - L) < 1e-12))


def test_closed_box_end_face_is_a_full_plate(meshes):
    open_, closed = meshes["box"], meshes["box_closed_p1"]
    # open tube: the end ring has no node in the cavity; closed: nodes at the centre region
    for mesh, has_centre in ((open_, False), (closed, True)):
        yz = mesh.points[mesh.groups["end_x0"], 1:]
        inner = np.all(np.abs(yz) < [0.03 - 0.006 - 1e-9, 0.04 - 0.006 - 1e-9], axis=1)
        assert inner.any() == has_centre


def test_mesh_is_deterministic():
    g, _ = CASES["plate"]
    a, b = build_mesh(g, "a"), build_mesh(g, "b")
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.cells["tetra10"], b.cells["tetra10"])


def _sigpipe_ignored() -> bool:
    with open("/proc/self/status") as fh:
        mask = next(int(line.split()[1], 16) for line in fh if line.startswith("SigIgn"))
    return bool(mask >> 12 & 1)  # bit n - 1 for signal n = 13


@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="needs Linux's /proc")
def test_meshing_in_this_process_keeps_sigpipe_ignored():
    """gmsh's initialisation resets SIGPIPE to terminate: after a mesh made in-process, a
    write to a closed socket (a study's Dask worker killed) killed the process silently
    (found as a test session that ended with exit status 141 midway)."""
    import signal
    import socket

    from pipeline.meshing.gmsh_build import gmsh_session

    assert _sigpipe_ignored()
    with gmsh_session("probe") as gmsh:
        gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
    assert _sigpipe_ignored() and signal.getsignal(signal.SIGPIPE) == signal.SIG_IGN
    a, b = socket.socketpair()
    b.close()
    with pytest.raises(BrokenPipeError):  # raised, not a dead process
        for _ in range(100):
            a.send(b"x" * 65536)
    a.close()
