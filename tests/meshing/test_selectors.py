"""Node selectors on a synthetic point cloud whose answers are known by construction."""

import numpy as np
import pytest

from pipeline.core.errors import ConfigError
from pipeline.meshing.selectors import (
    SELECTORS,
    BoxRegion,
    CylinderSurface,
    NearestNode,
    PhysicalGroup,
    PlaneFace,
)

RNG = np.random.default_rng(7)


def _cloud():
    """Points on a cylinder r=0.01 about the axis through (0.1, 0.02, 0) along (1, 1, 1),
    then points on the plane x = 0.3, then random points off both (seeded)."""
    axis = np.array([1.0, 1.0, 1.0]) / np.sqrt(3)
    e1 = np.cross(axis, [0, 0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    th, s = RNG.uniform(0, 2 * np.pi, 40), RNG.uniform(-0.05, 0.05, 40)
    cyl = np.array([0.1, 0.02, 0]) + np.outer(s, axis) + 0.01 * (
        np.outer(np.cos(th), e1) + np.outer(np.sin(th), e2))
    plane = np.column_stack([np.full(30, 0.3), RNG.uniform(-1, 1, (30, 2))])
    other = RNG.uniform(0.32, 0.5, (50, 3))
    return np.vstack([cyl, plane, other]), axis


def test_cylinder_plane_box_nearest_select_exactly_the_constructed_nodes():
    pts, axis = _cloud()
    all_ids = np.arange(len(pts))
    cyl = CylinderSurface(point=(0.1, 0.02, 0.0), axis=tuple(3 * axis), radius=0.01)
    np.testing.assert_array_equal(cyl.select(pts, all_ids, {}), np.arange(40))
    plane = PlaneFace(point=(0.3, 5.0, -2.0), normal=(-2.0, 0, 0))
    np.testing.assert_array_equal(plane.select(pts, all_ids, {}), np.arange(40, 70))
    box = BoxRegion(lo=(0.32, 0.32, 0.32), hi=(0.5, 0.5, 0.5))
    np.testing.assert_array_equal(box.select(pts, all_ids, {}), np.arange(70, 120))
    assert NearestNode(point=tuple(pts[77] + 1e-6)).select(pts, all_ids, {}).tolist() == [77]


def test_selection_is_restricted_to_candidates_and_sorted():
    pts, axis = _cloud()
    cand = np.array([65, 3, 41, 100, 5, 3])
    plane = PlaneFace(point=(0.3, 0, 0), normal=(1, 0, 0))
    assert plane.select(pts, cand, {}).tolist() == [41, 65]
    cyl = CylinderSurface(point=(0.1, 0.02, 0.0), axis=tuple(axis), radius=0.01)
    assert cyl.select(pts, cand, {}).tolist() == [3, 5]
    assert NearestNode(point=(0, 0, 0)).select(pts, [100, 101], {}).tolist() in ([100], [101])


def test_tolerance_band_of_cylinder():
    # nodes at radius 1, 1 + 5e-4 and 1 + 2e-3: default tol 1e-3 takes the first two
    pts = np.array([[1.0, 0, 0], [0, 1.0005, 0], [-1.002, 0, 0]])
    sel = CylinderSurface(point=(0, 0, 0), axis=(0, 0, 1), radius=1.0)
    assert sel.select(pts, np.arange(3), {}).tolist() == [0, 1]
    wide = CylinderSurface(point=(0, 0, 0), axis=(0, 0, 1), radius=1.0, tol=3e-3)
    assert wide.select(pts, np.arange(3), {}).tolist() == [0, 1, 2]


def test_physical_group_intersects_candidates_and_names_available_groups():
    pts = np.zeros((6, 3))
    groups = {"bore_A": np.array([0, 2, 4]), "end": np.array([5])}
    assert PhysicalGroup("bore_A").select(pts, [1, 2, 3, 4], groups).tolist() == [2, 4]
    with pytest.raises(ConfigError, match=r"unknown group 'bore_C'; available groups: "
                                          r"\['bore_A', 'end'\]"):
        PhysicalGroup("bore_C").select(pts, np.arange(6), groups)


def test_selector_matching_nothing_says_what_it_looked_for():
    pts, _ = _cloud()
    sel = CylinderSurface(point=(0, 0, 0), axis=(0, 0, 1), radius=0.5)
    with pytest.raises(ConfigError, match=r"CylinderSurface\(point=\(0.0, 0.0, 0.0\), "
                                          r"axis=\(0.0, 0.0, 1.0\), radius=0.5, tol=None\) "
                                          r"matched no boundary nodes"):
        sel.select(pts, np.arange(len(pts)), {})
    with pytest.raises(ConfigError, match=r"BoxRegion\(.*\) matched no boundary nodes"):
        BoxRegion((2, 2, 2), (3, 3, 3)).select(pts, np.arange(len(pts)), {})


@pytest.mark.parametrize("make, match", [
    (lambda: CylinderSurface((0, 0, 0), (0, 0, 0), 1.0),
     r"CylinderSurface.axis: expected a non-zero direction"),
    (lambda: CylinderSurface((0, 0, 0), (0, 0, 1), -1.0), r"CylinderSurface.radius"),
    (lambda: PlaneFace((0, 0), (0, 0, 1)), r"PlaneFace.point: expected shape \(3,\)"),
    (lambda: BoxRegion((0, 0, 1), (1, 1, 0)), r"expected lo <= hi"),
    (lambda: PhysicalGroup(""), r"PhysicalGroup.name"),
])
def test_bad_selector_fields(make, match):
    with pytest.raises(ConfigError, match=match):
        make()


def test_bad_candidates_are_rejected():
    pts = np.zeros((3, 3))
    with pytest.raises(ConfigError, match=r"expected ids in \[0, 3\)"):
        NearestNode((0, 0, 0)).select(pts, [0, 3], {})


def test_registry_matches_workflow_selector_types():
    from pipeline.workflow.link_spec import InterfaceSpec

    spec = InterfaceSpec.model_validate(
        {"name": "A", "selector": {"type": "cylinder", "point": [0, 0, 0], "axis": [0, 0, 1],
                                   "radius": 0.01}})
    fields = spec.selector.model_dump(exclude={"type"})
    sel = SELECTORS[spec.selector.type](**fields)
    assert isinstance(sel, CylinderSurface) and sel.radius == 0.01
    assert set(SELECTORS) == {"group", "cylinder", "plane", "nearest", "box"}
