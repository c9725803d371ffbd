"""Meshes beyond the machine are refused before gmsh runs (a solid at mesh_size 1e-9 ate
memory until killed; a beam at element_size 1e-9 gave 4 nodes, or never returned), and the
estimate behind the refusal is checked against real meshes."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.core.errors import MeshError
from pipeline.meshing import build_mesh
from pipeline.meshing.budget import check_mesh_budget, estimated_dof
from pipeline.meshing.geometry import BeamGeometry, SolidGeometry

BAR = {"L": 0.4, "b": 0.008, "h": 0.004}


def test_a_solid_mesh_beyond_the_memory_available_is_refused_before_meshing():
    with pytest.raises(MeshError, match=r"link 'bar': mesh_size 1e-09 m .* the memory budget is [\d.]+ GB"):
        build_mesh(SolidGeometry("bar", BAR, 1e-9, 2), "bar")


def test_the_budget_compares_the_estimate_with_the_memory_given():
    need = estimated_dof(1e-3, 1e-3, 2) * 10_000  # 1 litre at 1 mm
    check_mesh_budget(1e-3, 1e-3, 2, "x", available=int(2 * need))
    with pytest.raises(MeshError, match="x: mesh_size 0.001 m"):
        check_mesh_budget(1e-3, 1e-3, 2, "x", available=int(0.5 * need))


@pytest.mark.parametrize("size", [0.004, 0.002])
def test_the_estimate_does_not_exceed_the_real_mesh(size):
    """The estimate is a low one (so a mesh that fits is never refused): at most the real
    number of degrees of freedom, and within a factor 3 of it."""
    mesh = build_mesh(SolidGeometry("bar", BAR, size, 2), "bar")
    real = 3 * mesh.n_points
    est = estimated_dof(0.4 * 0.008 * 0.004, size, 2)
    assert real / 3 < est <= real


def test_a_beam_with_too_many_elements_is_refused_and_gmsh_is_held_to_the_size():
    pts = np.array([[0.0, 0, 0], [1.0, 0, 0], [1.0, 0.5, 0]])
    with pytest.raises(MeshError, match="would give 1.5e\\+09 elements"):
        build_mesh(BeamGeometry(points=pts, element_size=1e-9), "b")
    mesh = build_mesh(BeamGeometry(points=pts, element_size=0.3), "b")
    assert mesh.n_points == 4 + 2 + 1  # ceil(1 / 0.3) + ceil(0.5 / 0.3) elements
