"""Validation of link geometry descriptions and recipe parameters (no gmsh)."""

import numpy as np
import pytest

from pipeline.core.errors import ConfigError
from pipeline.meshing.geometry import BeamGeometry, SolidGeometry
from pipeline.meshing.recipe_params import (
    check_plate_bores,
    parse_bent_plate,
    parse_box_bores,
    parse_plate_bores,
)

ARM = {"points": [[0, 0], [1.2, -0.25], [1.75, -0.8]], "point_names": ["pivot", "knee", "tip"],
       "width": 0.16, "thickness": 0.02,
       "bores": [{"name": "pivot", "at": "pivot", "radius": 0.025}]}


def test_solid_geometry_normalises_and_freezes():
    g = SolidGeometry("geo", {}, 0.01, 1, "meshes/link_plate.geo")
    assert g.order == 1 and g.path.name == "link_plate.geo"
    with pytest.raises(TypeError):
        g.params["x"] = 1  # read-only mapping


@pytest.mark.parametrize("kwargs, match", [
    ({"recipe": "cube", "params": {}, "mesh_size": 0.01},
     r"geometry.recipe: expected one of .*'bar'"),
    ({"recipe": "bar", "params": {}, "mesh_size": -1.0},
     r"geometry.mesh_size: expected a finite value > 0, got -1.0"),
    ({"recipe": "bar", "params": {}, "mesh_size": 0.01, "order": 3}, r"geometry.order: expected 1 or 2"),
    ({"recipe": "bar", "params": [1], "mesh_size": 0.01}, r"geometry.params: expected a mapping"),
    ({"recipe": "step", "params": {}, "mesh_size": 0.01}, r"geometry.path: the 'step' recipe needs"),
])
def test_solid_geometry_rejects_bad_fields(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        SolidGeometry(**kwargs)


@pytest.mark.parametrize("kwargs, match", [
    ({"points": [[0, 0, 0]], "element_size": 1.0}, r"at least 2 vertices"),
    ({"points": [[0, 0, 0], [0, 0, 0]], "element_size": 1.0}, r"member 0 has zero length"),
    ({"points": [[0, 0], [1, 0]], "element_size": 1.0}, r"geometry.points: expected shape"),
    ({"points": [[0, 0, 0], [1, 0, 0]], "element_size": 0.0}, r"geometry.element_size"),
    ({"points": [[0, 0, 0], [1, 0, 0]], "element_size": 1.0, "vertex_names": ("a",)},
     r"expected 2 names"),
    ({"points": [[0, 0, 0], [1, 0, 0]], "element_size": 1.0, "vertex_names": ("a", "a")},
     r"duplicate names \['a'\]"),
    ({"points": [[0, 0, 0], [np.nan, 0, 0]], "element_size": 1.0}, r"expected finite numbers"),
])
def test_beam_geometry_rejects_bad_fields(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        BeamGeometry(**kwargs)


def test_plate_bores_parse_and_reject_overlap_and_outside():
    bores = parse_plate_bores([{"name": "A", "center": [0.03, 0], "radius": 0.01}], "link 'p'")
    assert bores[0].center == (0.03, 0.0) and bores[0].radius == 0.01
    check_plate_bores(bores, 0.2, 0.05, 0.0, "link 'p'")
    with pytest.raises(ConfigError, match=r"link 'p': params.bores: bores 'A' and 'B' overlap"):
        parse_plate_bores([{"name": "A", "center": [0, 0], "radius": 0.01},
                           {"name": "B", "center": [0.015, 0], "radius": 0.01}], "link 'p'")
    with pytest.raises(ConfigError, match=r"bore 'A' .* not inside the plate outline"):
        check_plate_bores(bores, 0.035, 0.05, 0.0, "link 'p'")
    # inside the rectangle, but cut by a rounded corner of radius 0.02
    corner = parse_plate_bores([{"name": "C", "center": [0.006, 0.019], "radius": 0.005}], "p")
    check_plate_bores(corner, 0.2, 0.05, 0.0, "p")
    with pytest.raises(ConfigError, match=r"bore 'C'"):
        check_plate_bores(corner, 0.2, 0.05, 0.02, "p")
    with pytest.raises(ConfigError, match=r"params.bores\[0\]: expected 'center'"):
        parse_plate_bores([{"name": "A", "radius": 0.01}], "p")
    with pytest.raises(ConfigError, match=r"params.bores\[0\].radius: expected a finite"):
        parse_plate_bores([{"name": "A", "center": [0, 0], "radius": -1}], "p")


def test_bent_plate_params():
    arm = parse_bent_plate(ARM, "link 'arm'")
    assert arm.knee_width == arm.width and arm.rounded_ends
    assert arm.bores[0].center == (0.0, 0.0)
    with pytest.raises(ConfigError, match=r"params.points: expected at least 2 points"):
        parse_bent_plate({**ARM, "points": [[0, 0]], "point_names": ["a"], "bores": []}, "a")
    with pytest.raises(ConfigError, match=r"params.bores\[0\].at: unknown point 'elbow'"):
        parse_bent_plate({**ARM, "bores": [{"name": "e", "at": "elbow", "radius": 0.01}]}, "a")
    # a pivot bore at a square end would be cut open
    with pytest.raises(ConfigError, match=r"bore 'pivot' .* not inside"):
        parse_bent_plate({**ARM, "rounded_ends": False}, "a")
    with pytest.raises(ConfigError, match=r"params.knee_width: expected >= width"):
        parse_bent_plate({**ARM, "knee_width": 0.1}, "a")
    with pytest.raises(ConfigError, match=r"params.colour: unknown parameter"):
        parse_bent_plate({**ARM, "colour": "yellow"}, "a")


def test_bent_plate_lugs_carry_bores_off_the_centre_lines():
    eye = {"name": "eye", "root": "knee", "center": [1.2, -0.55], "width": 0.1}
    arm = parse_bent_plate({**ARM, "lugs": [eye], "bores": [
        {"name": "eye", "at": "eye", "radius": 0.02}]}, "a")
    assert arm.lugs[0].root == (1.2, -0.25) and arm.bores[0].center == (1.2, -0.55)
    # the same bore without the lug would be outside the plate
    with pytest.raises(ConfigError, match=r"bore 'eye' .* not inside"):
        parse_bent_plate({**ARM, "bores": [{"name": "eye", "center": [1.2, -0.55],
                                            "radius": 0.02}]}, "a")
    # a bore wider than the lug's end is not inside it either
    with pytest.raises(ConfigError, match=r"bore 'eye' .* not inside"):
        parse_bent_plate({**ARM, "lugs": [eye], "bores": [
            {"name": "eye", "at": "eye", "radius": 0.06}]}, "a")
    with pytest.raises(ConfigError, match=r"params.lugs\[0\].root: expected a point inside"):
        parse_bent_plate({**ARM, "lugs": [{**eye, "root": [0.6, 0.3]}]}, "a")
    with pytest.raises(ConfigError, match=r"params.lugs\[0\].root: unknown point 'elbow'"):
        parse_bent_plate({**ARM, "lugs": [{**eye, "root": "elbow"}]}, "a")
    with pytest.raises(ConfigError, match=r"params.lugs: names \['knee'\] are point names"):
        parse_bent_plate({**ARM, "lugs": [{**eye, "name": "knee"}]}, "a")
    with pytest.raises(ConfigError, match=r"params.lugs\[0\]: expected the centre more than"):
        parse_bent_plate({**ARM, "lugs": [{**eye, "center": [1.2, -0.28]}]}, "a")


def test_box_bores_must_sit_in_flat_wall():
    ok = parse_box_bores([{"name": "p", "x": 0.05, "radius": 0.02, "axis": "y"}],
                         1.0, 0.1, 0.15, 0.008, 0.0, "b")
    assert ok[0].axis == "y" and ok[0].offset == 0.0
    with pytest.raises(ConfigError, match=r"cross_bores\[0\]: bore .* inside the flat part"):
        parse_box_bores([{"name": "p", "x": 0.05, "radius": 0.045, "axis": "z"}],
                        1.0, 0.1, 0.15, 0.008, 0.0, "b")
    with pytest.raises(ConfigError, match=r"cross_bores\[0\].axis: expected 'y' or 'z'"):
        parse_box_bores([{"name": "p", "x": 0.05, "radius": 0.01, "axis": "x"}],
                        1.0, 0.1, 0.15, 0.008, 0.0, "b")
