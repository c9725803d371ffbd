"""The whole reduction chain against independent references (gmsh + skfem)."""

import numpy as np
import pytest

pytestmark = pytest.mark.gmsh


def test_rigid_invariants_of_bar_equal_closed_form(bar_link):
    """Body frame at the root face centre, axes x_b = z, y_b = x... rotate the box tensors."""
    _, link = bar_link
    L, b, h, rho = 0.2, 0.02, 0.01, 2700.0
    m = rho * L * b * h
    R = link.body_pose[:3, :3]  # body axes in the geometry frame
    com_geo = np.array([L / 2, 0, 0])
    I_geo = m / 12 * np.diag([b**2 + h**2, L**2 + h**2, L**2 + b**2])
    assert link.mass == pytest.approx(m, rel=1e-10)
    np.testing.assert_allclose(link.center_of_mass, R.T @ com_geo, atol=1e-12)
    np.testing.assert_allclose(link.inertia_tensor, R.T @ I_geo @ R, rtol=0, atol=1e-8 * I_geo.max())


def test_modal_orthonormality_and_stiffness(bar_link):
    _, link = bar_link
    m = link.n_modes
    trace = np.trace(link.Cpp, axis1=2, axis2=3)
    np.testing.assert_allclose(trace, np.eye(m), atol=1e-8)
    omega2 = (2 * np.pi * link.frequencies_hz) ** 2
    np.testing.assert_allclose(link.modal_stiffness, np.diag(omega2), atol=1e-8 * omega2.max())
    assert np.all(np.diff(link.frequencies_hz) >= 0)


def test_first_moment_row_equals_independent_integral(bar_link):
    """C'_a[3, :3] = int rho phi_a dV, integrated here with skfem's own P2 basis."""
    from skfem import Basis, ElementTetP2, LinearForm

    from pipeline.fem.solid import p2_topology
    from pipeline.meshing import SolidGeometry, build_mesh

    _, link = bar_link
    mesh = build_mesh(SolidGeometry("bar", {"L": 0.2, "b": 0.02, "h": 0.01}, 0.01, 2), "bar")
    topo = p2_topology(mesh, "bar")
    basis = Basis(topo.mesh, ElementTetP2())
    ones = LinearForm(lambda v, w: 2700.0 * v).assemble(basis)  # (n_nodes,) in skfem order
    shapes = link.mode_shapes[:, topo.node_of_skfem, :]  # (m, n, 3), body frame
    np.testing.assert_allclose(np.einsum("n,mnk->mk", ones, shapes), link.Cp[:, 3, :3],
                               atol=1e-10 * np.abs(link.Cp).max())
    # and its fourth column (int rho r) is independent of the mode: C'_a[:, 3] = 0
    np.testing.assert_array_equal(link.Cp[:, :, 3], 0.0)


def test_frames_in_body_frame_consistent_with_nodal_shapes(bar_link):
    """RBE2 tip: every tip node moves as phi + psi x (x - o) in body coordinates."""
    _, link = bar_link
    ref, tip = link.frame("root"), link.frame("tip")
    np.testing.assert_allclose(ref.pose, np.eye(4), atol=1e-14)
    np.testing.assert_array_equal(ref.phi, 0.0)
    np.testing.assert_array_equal(ref.psi, 0.0)
    o = tip.pose[:3, 3]
    on_tip = np.abs(link.nodes[:, 2] - 0.2) < 1e-9  # body z = geometry x
    assert on_tip.sum() > 8
    r = link.nodes[on_tip] - o
    predicted = tip.phi[:, None, :] + np.cross(tip.psi[:, None, :], r[None])
    np.testing.assert_allclose(link.mode_shapes[:, on_tip], predicted,
                               atol=1e-10 * np.abs(link.mode_shapes).max())
    assert link.frame("mid").kind == "marker"


def test_plate_with_bores_matches_cad_and_error_falls(tmp_path):
    """FE mass properties vs gmsh OCC's CAD values: the reported error falls with h."""
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    errors = []
    for size, order in ((0.02, 2), (0.01, 2), (0.01, 1)):
        spec = tmp_path / f"plate{size}_{order}.yaml"
        spec.write_text(PLATE.format(size=size, order=order))
        link, _ = reduce_spec(load_link_spec(spec), tmp_path, tmp_path / "links")
        q = link.meta["mesh"]
        errors.append(q)
        assert q["mass_rel_error"] < (1e-4 if order == 2 else 1e-2)
        assert link.mass == pytest.approx(q["cad_mass_kg"], rel=q["mass_rel_error"] * 1.0001)
    assert errors[1]["mass_rel_error"] < errors[0]["mass_rel_error"]
    assert errors[1]["second_moment_rel_error"] < errors[0]["second_moment_rel_error"]
    # straight-sided (order 1) geometry on the same mesh size is worse than curved P2
    assert errors[2]["mass_rel_error"] > 10 * errors[1]["mass_rel_error"]


PLATE = """\
name: plate
geometry:
  type: solid
  recipe: plate_with_bores
  params:
    length: 0.3
    width: 0.1
    thickness: 0.01
    bores:
      - {{name: A, center: [0.05, 0.0], radius: 0.015}}
      - {{name: B, center: [0.25, 0.0], radius: 0.012}}
  mesh_size: {size}
  order: {order}
material: {{E: 2.1e11, nu: 0.3, rho: 7850}}
interfaces:
  - name: A
    selector: {{type: group, name: bore_A}}
    origin: [0.05, 0.0, 0]
  - name: B
    selector: {{type: group, name: bore_B}}
    origin: [0.25, 0.0, 0]
    kind: rbe3
reference: A
modes: {{count: 3}}
"""


def test_stress_modes_turn_to_the_body_axes_as_tensors():
    """Body axes x_b = z, y_b = x, z_b = y of the geometry: each body component is a
    geometry one (sigma_b_xx = sigma_zz, sigma_b_yz = sigma_xy, ...); for a general turn
    the invariants (trace, von Mises) stay and R sigma_b R^T gives the geometry tensor."""
    import types

    from scipy.spatial.transform import Rotation

    from pipeline.fem.stress import VOIGT, voigt_to_tensor, von_mises
    from pipeline.invariants.reduce import _stress_to_body

    solid = types.SimpleNamespace(kind="solid")
    S = np.random.default_rng(2).standard_normal((2, 7, 6)) * 1e6
    H = np.eye(4)
    H[:3, :3] = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 0]])  # columns: body axes
    Sb = _stress_to_body(solid, H, S)
    geo = {"xx": "zz", "yy": "xx", "zz": "yy", "yz": "xy", "xz": "yz", "xy": "xz"}
    for k, name in enumerate(VOIGT):
        np.testing.assert_allclose(Sb[..., k], S[..., VOIGT.index(geo[name])], rtol=1e-6)
    H[:3, :3] = Rotation.from_rotvec([0.4, -1.2, 0.9]).as_matrix()
    Sb = _stress_to_body(solid, H, S)
    R = H[:3, :3]
    back = np.einsum("ia,mnab,jb->mnij", R, voigt_to_tensor(Sb.astype(float)), R)
    np.testing.assert_allclose(back, voigt_to_tensor(S), rtol=0, atol=1e-6 * np.abs(S).max())
    np.testing.assert_allclose(von_mises(Sb), von_mises(S), rtol=1e-6)


@pytest.mark.parametrize("nu, warned", [(0.3, False), (0.4999999, True)])
def test_a_nearly_incompressible_solid_is_named_as_such(tmp_path, caplog, nu, warned):
    """nu -> 0.5 locks P2 tetrahedra volumetrically and its bulk stiffness sets off the
    round-off warning, which blamed the mesh (issue 24); the material is now named."""
    import logging

    from link_samples import write_bar

    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    path = write_bar(tmp_path, modes=2)
    path.write_text(path.read_text().replace("nu: 0.3", f"nu: {nu}"))
    with caplog.at_level(logging.WARNING, logger="pipeline"):
        reduce_spec(load_link_spec(path), tmp_path, tmp_path / "links")
    lines = [r.getMessage() for r in caplog.records if "nearly incompressible" in r.getMessage()]
    assert bool(lines) is warned
    if warned:
        assert f"link 'bar': material.nu = {nu:g} is nearly incompressible" in lines[0]
        assert "use nu <= 0.49" in lines[0]
