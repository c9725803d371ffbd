"""The vectorised P2 kernel against scikit-fem's own ``asm`` (independent
implementation: skfem's basis, mapping and ``linear_elasticity``/``mass`` forms),
node numbering of the model, and input errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from pipeline.core.errors import ConfigError, MeshError
from pipeline.fem import Material, assemble_solid, p2_topology
from pipeline.fem.p2_kernel import EDGES
from pipeline.meshing.mesh_data import MeshData

STEEL = Material(E=210e9, nu=0.3, rho=7850.0)


def jittered_box(seed: int = 0):
    """skfem MeshTet of an offset box with randomly moved vertices."""
    from skfem import MeshTet

    m = MeshTet.init_tensor(np.linspace(0, 0.3, 4), np.linspace(0, 0.1, 3), np.linspace(0, 0.05, 3))
    p = m.p + np.array([[0.2], [-0.1], [0.05]])
    p = p + 0.004 * np.random.default_rng(seed).standard_normal(p.shape)
    return MeshTet(p, m.t)


def curved_mesh(seed: int = 1):
    """skfem MeshTet2 whose midside nodes in x < 0.15 are moved (curved elements)."""
    from skfem import MeshTet2

    m2 = MeshTet2.from_mesh(jittered_box(seed))
    x = m2.doflocs.copy()
    nv = m2.nvertices
    bend = x[0, nv:] < 0.35
    x[:, nv:][:, bend] += 0.003 * np.sin(40.0 * x[[1, 2, 0]][:, nv:][:, bend])
    return MeshTet2(x, m2.t)


def as_tetra10(m2, order: str, seed: int = 2):
    """MeshData of a MeshTet2 with shuffled points; returns (mesh, original node of each point)."""
    nv = m2.nvertices
    cells = np.vstack([m2.t, nv + m2.t2e]).T
    if order == "gmsh":
        cells = cells[:, [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]]
    orig = np.random.default_rng(seed).permutation(m2.doflocs.shape[1])
    new_of_orig = np.argsort(orig)
    return MeshData(m2.doflocs.T[orig], {"tetra10": new_of_orig[cells]}, "solid", order=2), orig


def skfem_reference(mesh, intorder_k: int, intorder_m: int):
    """K, M (vector) and Ms (scalar) with skfem asm, and skfem node DOFs (n, 3)."""
    from skfem import Basis, BilinearForm, ElementTetP2, ElementVector, asm
    from skfem.helpers import dot
    from skfem.models.elasticity import linear_elasticity
    from skfem.models.poisson import mass as scalar_mass

    rho = STEEL.rho

    @BilinearForm
    def mass(u, v, w):
        return rho * dot(u, v)

    vec = ElementVector(ElementTetP2())
    K = asm(linear_elasticity(*STEEL.lame), Basis(mesh, vec, intorder=intorder_k))
    bm = Basis(mesh, vec, intorder=intorder_m)
    M = asm(mass, bm)
    Ms = rho * asm(scalar_mass, Basis(mesh, ElementTetP2(), intorder=intorder_m))
    return K, M, Ms, np.vstack([bm.nodal_dofs.T, bm.edge_dofs.T])


def rel_diff(A, B) -> float:
    return float(abs(sp.csr_matrix(A) - sp.csr_matrix(B)).max() / abs(B).max())


def test_affine_kernel_equals_skfem_asm():
    m = jittered_box()
    model = assemble_solid(MeshData(m.p.T, {"tetra": m.t.T}, "solid"), STEEL, "box")
    K0, M0, Ms0, dofs0 = skfem_reference(m, 4, 4)
    np.testing.assert_array_equal(model.node_dofs, dofs0)
    np.testing.assert_array_equal(model.nodes[: m.p.shape[1]], m.p.T)
    np.testing.assert_allclose(model.nodes[m.p.shape[1]:], m.p[:, m.edges].mean(axis=1).T)
    errs = [rel_diff(model.stiffness, K0), rel_diff(model.mass, M0),
            rel_diff(model.extras["scalar_mass"], Ms0)]
    print(f"\naffine {model.n_dof} DOF: relative differences K, M, Ms = {errs}")
    assert max(errs) < 1e-12
    assert abs(model.stiffness - model.stiffness.T).max() == 0.0


@pytest.mark.parametrize("order", ["meshio", "gmsh"])
def test_curved_kernel_equals_skfem_asm(order):
    m2 = curved_mesh()
    mesh, orig = as_tetra10(m2, order)
    model = assemble_solid(mesh, STEEL, "curved")
    straight = p2_topology(mesh, "link 'curved'").straight
    assert 0 < straight.sum() < straight.size  # both element kinds are exercised
    np.testing.assert_array_equal(model.nodes, mesh.points)
    K0, M0, Ms0, dofs0 = skfem_reference(m2, 4, 7)
    mine, ref = model.node_dofs.ravel(), dofs0[orig].ravel()
    errs = [rel_diff(model.stiffness[mine][:, mine], K0[ref][:, ref]),
            rel_diff(model.mass[mine][:, mine], M0[ref][:, ref]),
            rel_diff(model.extras["scalar_mass"], Ms0[orig][:, orig])]
    print(f"\ncurved ({order} order) {model.n_dof} DOF, {np.count_nonzero(~straight)} curved "
          f"cells: relative differences K, M, Ms = {errs}")
    assert max(errs) < 1e-12


def test_curved_mass_integrates_exactly():
    """Volume of a curved mesh from 1^T Ms 1 equals skfem's high-order quadrature."""
    from skfem import Basis, ElementTetP2, Functional

    m2 = curved_mesh()
    mesh, _ = as_tetra10(m2, "meshio")
    model = assemble_solid(mesh, Material(1.0, 0.3, 1.0), "curved")
    one = np.ones(model.n_nodes)
    vol = Functional(lambda w: 1.0 + 0.0 * w.x[0]).assemble(Basis(m2, ElementTetP2(), intorder=9))
    first = Functional(lambda w: w.x[0] ** 2).assemble(Basis(m2, ElementTetP2(), intorder=9))
    x = model.nodes[:, 0]
    assert one @ model.extras["scalar_mass"] @ one == pytest.approx(vol, rel=1e-13)
    assert x @ model.extras["scalar_mass"] @ x == pytest.approx(first, rel=1e-13)


@pytest.mark.parametrize("curved", [False, True])
def test_rigid_motions_are_stress_free(curved):
    if curved:
        mesh, _ = as_tetra10(curved_mesh(), "gmsh")
    else:
        m = jittered_box()
        mesh = MeshData(m.p.T, {"tetra": m.t.T}, "solid")
    model = assemble_solid(mesh, STEEL, "box")
    x = model.nodes - model.nodes.mean(axis=0)
    fields = [np.tile(np.eye(3)[a], (model.n_nodes, 1)) for a in range(3)]
    fields += [np.cross(np.eye(3)[a], x) for a in range(3)]
    R = np.zeros((model.n_dof, 6))
    for j, f in enumerate(fields):
        R[model.node_dofs, j] = f
    scale = abs(model.stiffness).max() * np.abs(R).max()
    assert np.abs(model.stiffness @ R).max() < 1e-10 * scale


def test_linear_mesh_numbering_boundary_and_cells():
    from skfem import MeshTet

    m = MeshTet.init_tensor(np.linspace(0, 1, 4), np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    model = assemble_solid(MeshData(m.p.T, {"tetra": m.t.T}, "solid"), STEEL, "cube")
    x = model.nodes
    on_face = np.any((np.abs(x) < 1e-12) | (np.abs(x - 1) < 1e-12), axis=1)
    np.testing.assert_array_equal(model.extras["boundary_nodes"], np.flatnonzero(on_face))
    cells = model.extras["cells"]
    e = np.array(EDGES)
    np.testing.assert_allclose(x[cells[:, 4:]], 0.5 * (x[cells[:, e[:, 0]]] + x[cells[:, e[:, 1]]]))
    assert model.extras["material"] == STEEL
    assert model.n_dof == 3 * model.n_nodes == np.unique(model.node_dofs).size


def test_material_errors_name_the_link_and_field():
    m = jittered_box()
    mesh = MeshData(m.p.T, {"tetra": m.t.T}, "solid")
    with pytest.raises(ConfigError, match=r"^link 'arm': material.nu: expected a value in "
                                          r"\(-1, 0.5\), got 0.5$"):
        assemble_solid(mesh, Material(70e9, 0.5, 2700.0), "arm")
    with pytest.raises(ConfigError, match=r"link 'arm': material.rho: expected a finite value "
                                          r"> 0, got -1.0"):
        assemble_solid(mesh, Material(70e9, 0.3, -1.0), "arm")
    with pytest.raises(ConfigError, match=r"material.E"):
        assemble_solid(mesh, Material(float("nan"), 0.3, 1.0), "arm")


def test_mesh_errors():
    m = jittered_box()
    extra_point = MeshData(np.vstack([m.p.T, [9.0, 9.0, 9.0]]), {"tetra": m.t.T}, "solid")
    with pytest.raises(MeshError, match="link 'a': mesh.points: 1 point"):
        assemble_solid(extra_point, STEEL, "a")
    flat = m.p.T.copy()
    flat[:, 2] = 0.0
    with pytest.raises(MeshError, match="degenerate"):
        assemble_solid(MeshData(flat, {"tetra": m.t.T}, "solid"), STEEL, "a")
    with pytest.raises(MeshError, match="expected 'tetra10' or 'tetra'"):
        assemble_solid(MeshData(m.p.T, {"triangle": m.t.T[:, :3]}, "solid"), STEEL, "a")
    mesh, _ = as_tetra10(curved_mesh(), "meshio")
    scrambled = np.asarray(mesh.cells["tetra10"]).copy()
    scrambled[:, 4:] = np.random.default_rng(0).permuted(scrambled[:, 4:], axis=1)
    with pytest.raises(MeshError, match="midside nodes"):
        assemble_solid(MeshData(mesh.points, {"tetra10": scrambled}, "solid"), STEEL, "a")


def test_quadratic_mesh_boundary_nodes_follow_the_point_order():
    from skfem import MeshTet, MeshTet2

    m = MeshTet.init_tensor(np.linspace(0, 1, 4), np.linspace(0, 1, 3), np.linspace(0, 1, 3))
    mesh, _ = as_tetra10(MeshTet2.from_mesh(m), "gmsh")
    model = assemble_solid(mesh, STEEL, "cube")
    x = mesh.points
    on_face = np.any((np.abs(x) < 1e-12) | (np.abs(x - 1) < 1e-12), axis=1)
    np.testing.assert_array_equal(model.extras["boundary_nodes"], np.flatnonzero(on_face))
    assert p2_topology(mesh, "cube").straight.all()


@pytest.mark.parametrize("order", ["meshio", "gmsh"])
def test_single_cell_midside_order_decided_by_geometry(order):
    from skfem import MeshTet, MeshTet2

    mesh, _ = as_tetra10(MeshTet2.from_mesh(MeshTet.init_refdom()), order)
    model = assemble_solid(mesh, Material(1.0, 0.3, 1.0), "one")
    assert p2_topology(mesh, "one").straight.all()
    assert model.extras["scalar_mass"].sum() == pytest.approx(1.0 / 6.0, rel=1e-14)


@pytest.mark.gmsh
def test_gmsh_curved_plate_matches_cad_and_skfem():
    """A gmsh tetra10 plate with bores: curved cells, volume and centroid vs the OCC solid."""
    from pipeline.meshing import SolidGeometry, build_mesh

    params = {"length": 0.2, "width": 0.05, "thickness": 0.01,
              "bores": [{"name": "a", "center": [0.03, 0.0], "radius": 0.01},
                        {"name": "b", "center": [0.17, 0.0], "radius": 0.008}]}
    mesh = build_mesh(SolidGeometry("plate_with_bores", params, mesh_size=0.006), "plate")
    model = assemble_solid(mesh, STEEL, "plate")
    topo = p2_topology(mesh, "plate")
    assert np.count_nonzero(~topo.straight) > 0
    np.testing.assert_array_equal(model.nodes, mesh.points)
    Ms = model.extras["scalar_mass"] / STEEL.rho
    vol = Ms.sum()
    centroid = (model.nodes.T @ Ms.sum(axis=1).A1) / vol
    print(f"\ngmsh plate: {model.n_dof} DOF, volume error {vol / mesh.cad['volume'] - 1:.2e}")
    assert vol == pytest.approx(float(mesh.cad["volume"]), rel=1e-4)
    np.testing.assert_allclose(centroid, mesh.cad["centroid"], atol=1e-6)
    K0, M0, _, dofs0 = skfem_reference(topo.mesh, 4, 7)
    np.testing.assert_array_equal(model.node_dofs, dofs0[np.argsort(topo.node_of_skfem)])
    assert rel_diff(model.stiffness, K0) < 1e-12
    assert rel_diff(model.mass, M0) < 1e-12
