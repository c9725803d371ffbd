"""OCC mass properties in MeshData.cad against closed forms; mesh volume convergence."""

import numpy as np
import pytest

from pipeline.meshing import SolidGeometry, build_mesh
from tests.meshing.conftest import signed_tet_volumes

pytestmark = pytest.mark.gmsh


def box_moments(lo, size):
    """Volume, centroid and S = int x x^T dV of an axis-aligned box (closed form)."""
    lo, size = np.asarray(lo, float), np.asarray(size, float)
    hi = lo + size
    V = size.prod()
    c = (lo + hi) / 2
    S = V * np.outer(c, c) + np.diag(V * size**2 / 12)
    # diagonal directly: int x^2 dV = (hi^3 - lo^3)/3 * (other two sides)
    np.testing.assert_allclose(np.diag(S), (hi**3 - lo**3) / 3 * V / size)
    return V, c, S


def cylinder_moments(center, r, t):
    """z-axis cylinder of radius r, height t centred at ``center`` (closed form)."""
    c = np.asarray(center, float)
    V = np.pi * r**2 * t
    Sc = np.diag([np.pi * r**4 * t / 4, np.pi * r**4 * t / 4, V * t**2 / 12])
    return V, c, Sc + V * np.outer(c, c)


def _check(cad, V, c, S):
    np.testing.assert_allclose(float(cad["volume"]), V, rtol=1e-9)
    np.testing.assert_allclose(cad["centroid"], c, rtol=1e-9, atol=1e-9 * np.abs(c).max())
    np.testing.assert_allclose(cad["second_moment"], S, rtol=1e-9, atol=1e-9 * np.abs(S).max())


def test_bar_cad_matches_box_closed_form():
    L, b, h = 0.4, 0.008, 0.004
    mesh = build_mesh(SolidGeometry("bar", {"L": L, "b": b, "h": h}, 0.004, 1), "bar")
    _check(mesh.cad, *box_moments([0, -b / 2, -h / 2], [L, b, h]))
    # a box is meshed exactly by straight tets
    np.testing.assert_allclose(signed_tet_volumes(mesh.points, mesh.cells["tetra"]).sum(),
                               L * b * h, rtol=1e-12)


def test_plate_with_bores_cad_is_plate_minus_cylinders():
    L, w, t = 0.2, 0.05, 0.01
    bores = [((0.03, 0.0), 0.01), ((0.17, 0.012), 0.008), ((0.1, -0.01), 0.005)]
    params = {"length": L, "width": w, "thickness": t,
              "bores": [{"name": f"b{i}", "center": list(c), "radius": r}
                        for i, (c, r) in enumerate(bores)]}
    mesh = build_mesh(SolidGeometry("plate_with_bores", params, 0.01, 1), "plate")
    V, c1, S = box_moments([0, -w / 2, -t / 2], [L, w, t])
    first = V * c1
    for (x, y), r in bores:
        v, c, s = cylinder_moments([x, y, 0.0], r, t)
        V, first, S = V - v, first - v * c, S - s
    assert abs(S[0, 1]) > 1e-3 * abs(S).max()  # the off-centre bores give products of inertia
    _check(mesh.cad, V, first / V, S)


def test_linear_tet_volume_converges_to_cad_volume():
    """Straight tets inscribe the bores: error ~ h^2 (chord error); report the numbers."""
    params = {"length": 0.1, "width": 0.04, "thickness": 0.006,
              "bores": [{"name": "A", "center": [0.02, 0], "radius": 0.01},
                        {"name": "B", "center": [0.075, 0], "radius": 0.008}]}
    errors = []
    for h in (0.008, 0.004, 0.002):
        mesh = build_mesh(SolidGeometry("plate_with_bores", params, h, 1), "plate")
        vol = signed_tet_volumes(mesh.points, mesh.cells["tetra"]).sum()
        errors.append((vol - float(mesh.cad["volume"])) / float(mesh.cad["volume"]))
    print("relative volume error at h = 8, 4, 2 mm:", errors)
    errors = np.array(errors)
    assert np.all(errors > 0)  # the straight-sided bores remove less material than the CAD
    rates = np.log2(errors[:-1] / errors[1:])  # measured 1.33, 1.96 (h = 8 mm is coarse:
    assert np.all(rates > 1.0), rates          # a few chords per bore), tending to 2
    assert rates[-1] > 1.8, rates
    assert errors[-1] < 1e-3


def test_occ_inertia_convention_on_a_rotated_box(tmp_path):
    """getMatrixOfInertia is about the centroid with I = tr(S_c) 1 - S_c: a rotated,
    shifted box (written to STEP, read back by the step recipe) has S = R S0 R^T + V c c^T."""
    import gmsh

    size, lo = np.array([0.3, 0.05, 0.02]), np.array([0.1, -0.2, 0.05])
    axis, angle = np.array([1.0, 2.0, 2.0]) / 3.0, 0.7
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    path = tmp_path / "rotated_box.step"
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setString("Geometry.OCCTargetUnit", "M")
        box = gmsh.model.occ.addBox(*lo, *size)
        gmsh.model.occ.rotate([(3, box)], 0, 0, 0, *axis, angle)
        gmsh.model.occ.synchronize()
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    mesh = build_mesh(SolidGeometry("step", {}, 0.02, 1, path), "rotated")
    V, c0, S0 = box_moments(lo, size)
    c = R @ c0
    S = R @ (S0 - V * np.outer(c0, c0)) @ R.T + V * np.outer(c, c)
    _check(mesh.cad, V, c, S)
    np.testing.assert_allclose(signed_tet_volumes(mesh.points, mesh.cells["tetra"]).sum(), V,
                               rtol=1e-9)
