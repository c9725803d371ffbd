"""Beam element matrices vs the textbook 12x12 frame element; section and mesh checks.

Reference matrices: Przemieniecki, *Theory of Matrix Structural Analysis*
(1968), eqs. 5.116 (stiffness), 11.43 (consistent mass) and 11.51 (rotary
inertia of a Rayleigh beam); local order [u, v, w, rx, ry, rz] x 2 nodes.
"""

import numpy as np
import pytest

from pipeline.core.errors import ConfigError, MeshError
from pipeline.fem.beam import assemble_beam, sections_by_member
from pipeline.fem.section import BeamSection, check_section, element_frames
from pipeline.meshing.mesh_data import MeshData

SEC = dict(A=3e-4, Iy=5e-8, Iz=2e-8, J=4e-8, E=2.1e11, G=8.1e10, rho=7850.0)


def _sym(upper: dict, n=12) -> np.ndarray:
    K = np.zeros((n, n))
    for (i, j), v in upper.items():
        K[i, j] = K[j, i] = v
    return K


def textbook_stiffness(L, A, Iy, Iz, J, E, G, **_):
    a, t = E * A / L, G * J / L
    y3, y2, y1 = E * Iy / L**3, E * Iy / L**2, E * Iy / L
    z3, z2, z1 = E * Iz / L**3, E * Iz / L**2, E * Iz / L
    return _sym({
        (0, 0): a, (0, 6): -a, (6, 6): a, (3, 3): t, (3, 9): -t, (9, 9): t,
        (1, 1): 12 * z3, (1, 5): 6 * z2, (1, 7): -12 * z3, (1, 11): 6 * z2,
        (5, 5): 4 * z1, (5, 7): -6 * z2, (5, 11): 2 * z1, (7, 7): 12 * z3,
        (7, 11): -6 * z2, (11, 11): 4 * z1,
        (2, 2): 12 * y3, (2, 4): -6 * y2, (2, 8): -12 * y3, (2, 10): -6 * y2,
        (4, 4): 4 * y1, (4, 8): 6 * y2, (4, 10): 2 * y1, (8, 8): 12 * y3,
        (8, 10): 6 * y2, (10, 10): 4 * y1,
    })


def textbook_mass(L, A, Iy, Iz, rho, **_):
    m = rho * A * L / 420
    trans = _sym({
        (0, 0): 140, (0, 6): 70, (6, 6): 140,
        (1, 1): 156, (1, 5): 22 * L, (1, 7): 54, (1, 11): -13 * L, (5, 5): 4 * L**2,
        (5, 7): 13 * L, (5, 11): -3 * L**2, (7, 7): 156, (7, 11): -22 * L, (11, 11): 4 * L**2,
        (2, 2): 156, (2, 4): -22 * L, (2, 8): 54, (2, 10): 13 * L, (4, 4): 4 * L**2,
        (4, 8): -13 * L, (4, 10): -3 * L**2, (8, 8): 156, (8, 10): 22 * L, (10, 10): 4 * L**2,
    }) * m
    tors = _sym({(3, 3): 2, (3, 9): 1, (9, 9): 2}) * rho * (Iy + Iz) * L / 6
    rz = _sym({(1, 1): 36, (1, 5): 3 * L, (1, 7): -36, (1, 11): 3 * L, (5, 5): 4 * L**2,
               (5, 7): -3 * L, (5, 11): -L**2, (7, 7): 36, (7, 11): -3 * L,
               (11, 11): 4 * L**2}) * rho * Iz / (30 * L)
    ry = _sym({(2, 2): 36, (2, 4): -3 * L, (2, 8): -36, (2, 10): -3 * L, (4, 4): 4 * L**2,
               (4, 8): 3 * L, (4, 10): -L**2, (8, 8): 36, (8, 10): 3 * L,
               (10, 10): 4 * L**2}) * rho * Iy / (30 * L)
    return trans + tors + rz + ry


def _rotation(e_x, y_hint):
    ex = np.asarray(e_x, float) / np.linalg.norm(e_x)
    ey = np.asarray(y_hint, float) - np.dot(y_hint, ex) * ex
    ey /= np.linalg.norm(ey)
    return np.array([ex, ey, np.cross(ex, ey)])


@pytest.mark.parametrize("direction, y_axis", [
    ((1.0, 0.0, 0.0), None),
    ((0.3, -1.2, 0.7), (0.2, 0.5, 1.0)),
    ((-2.0, 0.4, -1.0), None),
])
def test_single_element_matches_textbook_in_any_orientation(direction, y_axis):
    p0 = np.array([0.4, -0.3, 1.1])
    L = 0.75
    e = np.asarray(direction) / np.linalg.norm(direction)
    mesh = MeshData(points=[p0, p0 + L * e], cells={"line": [[0, 1]]}, kind="beam")
    model = assemble_beam(mesh, BeamSection(**SEC, y_axis=y_axis), "bar")
    # The default rule (documented): y = Z x e_x normalised.
    R = _rotation(e, y_axis if y_axis is not None else np.cross([0, 0, 1.0], e))
    T = np.kron(np.eye(4), R)  # local = T @ link
    K_ref = T.T @ textbook_stiffness(L, **SEC) @ T
    M_ref = T.T @ textbook_mass(L, **SEC) @ T
    assert np.abs(model.stiffness.toarray() - K_ref).max() < 1e-12 * np.abs(K_ref).max()
    assert np.abs(model.mass.toarray() - M_ref).max() < 1e-12 * np.abs(M_ref).max()
    np.testing.assert_allclose(model.extras["frames"][0], R, atol=1e-14)


def test_frames_are_proper_rotations_and_vertical_fallback():
    rng = np.random.default_rng(3)
    d = rng.standard_normal((50, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    d[0] = [0.0, 0.0, -1.0]  # vertical: y falls back to global Y
    R = element_frames(d, np.full((50, 3), np.nan), "beam")
    np.testing.assert_allclose(np.einsum("kij,klj->kil", R, R), np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
    np.testing.assert_allclose(R[:, 0], d, atol=1e-15)
    np.testing.assert_allclose(R[0], [[0, 0, -1], [0, 1, 0], [1, 0, 0]], atol=1e-15)  # z = -Z x Y = X
    # Non-vertical defaults have a horizontal y axis.
    assert np.abs(R[1:, 1, 2]).max() < 1e-15


@pytest.mark.parametrize("field, value", [("A", -1.0), ("Iy", 0.0), ("Iz", np.nan),
                                          ("J", -2e-8), ("E", np.inf), ("G", 0), ("rho", -7850)])
def test_check_section_names_link_and_field(field, value):
    bad = BeamSection(**{**SEC, field: value})
    with pytest.raises(ConfigError, match=rf"link 'arm': sections\[2\]\.{field}: expected a "
                                          rf"finite value > 0"):
        check_section(bad, "link 'arm': sections[2]")


def test_bad_y_axis_is_rejected():
    with pytest.raises(ConfigError, match=r"sections\[0\]\.y_axis: expected 3 finite numbers"):
        check_section(BeamSection(**SEC, y_axis=(0, 0, 0)), "link 'arm': sections[0]")
    with pytest.raises(ConfigError, match="y_axis"):
        check_section(BeamSection(**SEC, y_axis=(1, 2)), "link 'arm': sections[0]")
    with pytest.raises(ConfigError, match="BeamSection.y_axis: expected 3 numbers"):
        BeamSection(**SEC, y_axis=("a", "b", "c"))
    mesh = MeshData(points=[[0, 0, 0], [0, 0, 2.0]], cells={"line": [[0, 1]]}, kind="beam")
    with pytest.raises(ConfigError, match=r"link 'mast': element 0: section y_axis .* parallel"):
        assemble_beam(mesh, BeamSection(**SEC, y_axis=(0, 0, 5)), "mast")


def test_assembly_input_errors():
    pts = [[0, 0, 0], [1, 0, 0], [2, 0, 0]]
    ok = MeshData(points=pts, cells={"line": [[0, 1], [1, 2]]}, kind="beam")
    sec = BeamSection(**SEC)
    with pytest.raises(ConfigError, match=r"link 'boom': sections: expected 1 or 2 .* got 3"):
        assemble_beam(ok, [sec] * 3, "boom")
    with pytest.raises(ConfigError, match=r"link 'boom': sections\[1\]\.E"):
        assemble_beam(ok, [sec, BeamSection(**{**SEC, "E": -1.0})], "boom")
    solid = MeshData(points=pts, cells={"line": [[0, 1], [1, 2]]}, kind="solid")
    with pytest.raises(ConfigError, match=r"link 'boom': mesh.kind: expected 'beam'"):
        assemble_beam(solid, sec, "boom")
    orphan = MeshData(points=pts, cells={"line": [[0, 1]]}, kind="beam")
    with pytest.raises(MeshError, match=r"link 'boom': mesh points \[2\] belong to no beam"):
        assemble_beam(orphan, sec, "boom")
    zero = MeshData(points=[[0, 0, 0], [0, 0, 0]], cells={"line": [[0, 1]]}, kind="beam")
    with pytest.raises(MeshError, match=r"link 'boom': beam element 0 .* zero length"):
        assemble_beam(zero, sec, "boom")
    empty = MeshData(points=pts, cells={}, kind="beam")
    with pytest.raises(MeshError, match=r"cells\['line'\]"):
        assemble_beam(empty, sec, "boom")


def test_sections_by_member_follows_member_groups():
    pts = [[0, 0, 0], [0.5, 0, 0], [1, 0, 0], [1, 1, 0], [1, 2, 0]]
    cells = [[2, 3], [0, 1], [3, 4], [1, 2]]  # any cell order
    groups = {"member_0": [0, 1, 2], "member_1": [2, 3, 4]}
    mesh = MeshData(points=pts, cells={"line": cells}, kind="beam", groups=groups)
    s0, s1 = BeamSection(**SEC), BeamSection(**{**SEC, "A": 1e-3})
    assert sections_by_member(mesh, [s0, s1], "frame") == (s1, s0, s1, s0)
    with pytest.raises(ConfigError, match="link 'frame': .* no node group 'member_2'"):
        sections_by_member(mesh, [s0, s1, s0], "frame")
    with pytest.raises(ConfigError, match=r"link 'frame': element 0 \[2, 3\] lies in no member"):
        sections_by_member(mesh, [s0], "frame")
