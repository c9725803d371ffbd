"""Beam links: gmsh 1D mesh of a polyline, nodes and cells ordered along it."""

import numpy as np
import pytest

from pipeline.meshing import BeamGeometry, build_mesh

pytestmark = pytest.mark.gmsh


def _check_chain(mesh, geometry):
    pts, cells = mesh.points, mesh.cells["line"]
    n = mesh.n_points
    np.testing.assert_array_equal(cells, np.column_stack([np.arange(n - 1), np.arange(1, n)]))
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    total = np.linalg.norm(np.diff(geometry.points, axis=0), axis=1).sum()
    np.testing.assert_allclose(seg.sum(), total, rtol=1e-12)  # no gaps, no back-steps
    assert seg.max() <= geometry.element_size * (1 + 1e-9)
    assert mesh.kind == "beam" and dict(mesh.boundary) == {} and dict(mesh.cad) == {}


def test_straight_beam():
    g = BeamGeometry([[0, 0, 0], [0, 0, 24.0]], 1.0, ("pivot", "tip"))
    mesh = build_mesh(g, "boom")
    _check_chain(mesh, g)
    assert mesh.n_points == 25
    np.testing.assert_allclose(mesh.points[:, 2], np.arange(25.0), atol=1e-12)
    assert mesh.groups["pivot"].tolist() == [0] and mesh.groups["tip"].tolist() == [24]
    np.testing.assert_array_equal(mesh.groups["member_0"], np.arange(25))


def test_polyline_beam_vertices_members_and_order():
    # the seed's boom: three 8 m sections, here bent in space so each member differs
    verts = np.array([[0, 0, 0], [8, 0, 0], [14, 5.0, 0], [14, 5, 7.5]])
    g = BeamGeometry(verts, 0.7, ("pivot", "s1", "s2", "tip"))
    mesh = build_mesh(g, "boom")
    _check_chain(mesh, g)
    for k, name in enumerate(g.vertex_names):
        (node,) = mesh.groups[name]
        np.testing.assert_allclose(mesh.points[node], verts[k], atol=1e-12)
    for i in range(3):
        ids = mesh.groups[f"member_{i}"]
        np.testing.assert_array_equal(ids, np.arange(ids[0], ids[-1] + 1))
        assert ids[0] == mesh.groups[g.vertex_names[i]][0]
        assert ids[-1] == mesh.groups[g.vertex_names[i + 1]][0]
        # member nodes are on the member's straight segment
        a, b = verts[i], verts[i + 1]
        rel = mesh.points[ids] - a
        d = (b - a) / np.linalg.norm(b - a)
        np.testing.assert_allclose(rel - np.outer(rel @ d, d), 0, atol=1e-12)
        # gmsh splits a member of length l at size h into ceil(l / h) elements
        assert len(ids) - 1 == int(np.ceil(np.linalg.norm(b - a) / 0.7 - 1e-9))


def test_unnamed_beam_has_member_groups_only():
    mesh = build_mesh(BeamGeometry([[0, 0, 0], [1, 1, 0], [2, 0, 0]], 0.5), "frame")
    assert set(mesh.groups) == {"member_0", "member_1"}
