"""File-based recipes (.geo, STEP), error reporting and gmsh life cycle."""

from pathlib import Path

import numpy as np
import pytest

from pipeline.core.errors import ConfigError, MeshError
from pipeline.meshing import CylinderSurface, SolidGeometry, build_mesh
from pipeline.meshing.gmsh_build import gmsh_session
from tests.meshing.conftest import assert_valid_solid, min_p2_jacobian

pytestmark = pytest.mark.gmsh

GEO = Path(__file__).resolve().parents[2] / "meshes" / "link_plate.geo"


def _gmsh_initialized():
    import gmsh

    return gmsh.isInitialized()


def test_geo_file_link_plate_groups_and_cad():
    mesh = build_mesh(SolidGeometry("geo", {}, 0.004, 2, GEO), "link_plate")
    assert_valid_solid(mesh)
    assert {"bore_A", "bore_B", "plate"} <= set(mesh.groups)
    # values written in meshes/link_plate.geo
    L, w, t, rA, rB = 0.12, 0.03, 0.006, 0.006, 0.005
    V = t * (L * w + np.pi * (w / 2) ** 2 - np.pi * (rA**2 + rB**2))
    np.testing.assert_allclose(float(mesh.cad["volume"]), V, rtol=1e-9)
    # first moment: strip + two half discs (centroids -/+ 4R/(3 pi) beyond the ends) - bore B
    R = w / 2
    first_x = t * (L * w * L / 2 + np.pi * R**2 / 2 * (-4 * R / (3 * np.pi))
                   + np.pi * R**2 / 2 * (L + 4 * R / (3 * np.pi)) - np.pi * rB**2 * L)
    np.testing.assert_allclose(mesh.cad["centroid"], [first_x / V, 0, 0], atol=1e-12)
    # the file's physical groups are exactly the nodes the cylinder selector finds
    boundary = np.unique(mesh.boundary["triangle6"])
    for group, point, r in (("bore_A", (0, 0, 0), rA), ("bore_B", (L, 0, 0), rB)):
        sel = CylinderSurface(point=point, axis=(0, 0, 1), radius=r)
        np.testing.assert_array_equal(sel.select(mesh.points, boundary, mesh.groups),
                                      mesh.groups[group])
    np.testing.assert_array_equal(mesh.groups["plate"], np.arange(mesh.n_points))
    assert not _gmsh_initialized()


def test_step_roundtrip_of_an_occ_box(tmp_path):
    import gmsh

    path = tmp_path / "box.step"
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setString("Geometry.OCCTargetUnit", "M")  # file written in mm
        gmsh.model.occ.addBox(0, 0, 0, 0.3, 0.02, 0.01)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    assert "MILLI" in path.read_text()
    mesh = build_mesh(SolidGeometry("step", {}, 0.005, 2, path), "stepbox")
    assert_valid_solid(mesh)
    np.testing.assert_allclose(mesh.points.min(axis=0), [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(mesh.points.max(axis=0), [0.3, 0.02, 0.01], rtol=1e-12)
    np.testing.assert_allclose(float(mesh.cad["volume"]), 0.3 * 0.02 * 0.01, rtol=1e-9)
    assert dict(mesh.groups) == {}  # STEP interfaces are found by selectors, not by name
    assert not _gmsh_initialized()


@pytest.mark.parametrize("recipe, suffix", [("geo", ".geo"), ("step", ".step")])
def test_missing_file_is_a_mesh_error_naming_link_and_path(tmp_path, recipe, suffix):
    missing = tmp_path / f"nope{suffix}"
    with pytest.raises(MeshError, match=rf"link 'arm': geometry file not found: .*nope\{suffix}"):
        build_mesh(SolidGeometry(recipe, {}, 0.01, 1, missing), "arm")
    assert not _gmsh_initialized()


def test_gmsh_failure_is_a_mesh_error_with_gmsh_message(tmp_path):
    bad = tmp_path / "bad.geo"
    bad.write_text('SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 1, 1;\n')
    with pytest.raises(MeshError, match=r"link 'lever': gmsh failed: .*bad.geo"):
        build_mesh(SolidGeometry("geo", {}, 0.1, 1, bad), "lever")
    assert not _gmsh_initialized()


def test_geometry_without_volume_is_a_mesh_error(tmp_path):
    flat = tmp_path / "flat.geo"
    flat.write_text('SetFactory("OpenCASCADE");\nRectangle(1) = {0, 0, 0, 1, 1};\n')
    with pytest.raises(MeshError, match=r"link 'sheet': geometry 'geo' has no volume to mesh"):
        build_mesh(SolidGeometry("geo", {}, 0.1, 1, flat), "sheet")
    assert not _gmsh_initialized()


@pytest.mark.parametrize("recipe, params, match", [
    ("bar", {"L": -0.4, "b": 0.01, "h": 0.01},
     r"link 'arm': params.L: expected a finite value > 0, got -0.4"),
    ("bar", {"L": 0.4, "b": 0.01}, r"link 'arm': params.h: missing; required \['L', 'b', 'h'\]"),
    ("bar", {"L": 0.4, "b": 0.01, "h": 0.01, "hh": 1}, r"params.hh: unknown parameter"),
    ("plate_with_bores", {"length": 0.1, "width": 0.02, "thickness": 0.01,
                          "bores": [{"name": "A", "center": [0.005, 0], "radius": 0.01}]},
     r"link 'arm': params.bores: bore 'A' .* not inside the plate outline"),
    ("box_section", {"length": 1, "b": 0.1, "h": 0.1, "wall": 0.06},
     r"link 'arm': params.wall: expected a value < min\(b, h\)/2"),
    ("step", {"scale": 1000}, r"params.scale: unknown parameter"),
])
def test_bad_params_are_config_errors_and_gmsh_is_finalized(recipe, params, match):
    with pytest.raises(ConfigError, match=match):
        build_mesh(SolidGeometry(recipe, params, 0.01, 1, "x.step"), "arm")
    assert not _gmsh_initialized()


def test_session_of_a_caller_keeps_its_gmsh_and_removes_only_its_model():
    import gmsh

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("callers_model")
        before = gmsh.model.list()
        mesh = build_mesh(SolidGeometry("bar", {"L": 0.1, "b": 0.01, "h": 0.01}, 0.01, 1), "b")
        assert mesh.n_points > 8
        assert gmsh.isInitialized() and gmsh.model.list() == before
        assert gmsh.model.getCurrent() == "callers_model"
    finally:
        gmsh.finalize()


def test_session_finalizes_after_an_unexpected_error():
    with pytest.raises(MeshError, match=r"link 'x': gmsh failed: boom"), gmsh_session("x"):
        raise RuntimeError("boom")
    assert not _gmsh_initialized()


def test_inverted_curved_elements_are_straightened(caplog):
    """A 0.16 m wide arm with 20-25 mm bores meshed at 30 mm: curving the coarse bore
    edges onto the CAD inverts a tet (gmsh 4.15); it must come back valid."""
    arm = {"points": [[0, 0], [1.2, -0.25], [1.75, -0.8]],
           "point_names": ["pivot", "knee", "tip"], "width": 0.16, "knee_width": 0.22,
           "thickness": 0.02,
           "bores": [{"name": "pivot", "at": "pivot", "radius": 0.025},
                     {"name": "cyl", "at": "knee", "radius": 0.02},
                     {"name": "tip", "at": "tip", "radius": 0.02}]}
    with caplog.at_level("WARNING", logger="pipeline.meshing.gmsh_build"):
        mesh = build_mesh(SolidGeometry("bent_plate", arm, 0.03, 2), "arm")
    assert "straightened" in caplog.text
    assert min_p2_jacobian(mesh.points, mesh.cells["tetra10"]) > 0
    assert_valid_solid(mesh)


def test_builtin_kernel_geo_meshes_without_cad_properties(tmp_path):
    """A .geo without SetFactory("OpenCASCADE") has no exact CAD: cad is empty."""
    geo = tmp_path / "builtin.geo"
    geo.write_text("Point(1) = {0, 0, 0};\nPoint(2) = {0.1, 0, 0};\nLine(1) = {1, 2};\n"
                   "e[] = Extrude {0, 0.02, 0} { Line{1}; };\n"
                   "v[] = Extrude {0, 0, 0.01} { Surface{e[1]}; };\n"
                   'Physical Volume("all") = {v[1]};\n')
    mesh = build_mesh(SolidGeometry("geo", {}, 0.01, 2, geo), "builtin")
    vol = assert_valid_solid(mesh)
    np.testing.assert_allclose(vol.sum(), 0.1 * 0.02 * 0.01, rtol=1e-12)
    assert dict(mesh.cad) == {}
    np.testing.assert_array_equal(mesh.groups["all"], np.arange(mesh.n_points))
