"""A solid of several materials, assigned by element set (issue 28): checked against the
closed-form state of a bar of two materials in series.

Steel (E1, nu1) for x < a and a second material (E2, nu2) beyond, with nu1 / E1 = nu2 / E2,
under a uniform axial stress s: both parts then contract alike sideways, so the exact
field is piecewise linear,

    u_x = s x / E1 (x <= a),  s a / E1 + s (x - a) / E2 (x > a),
    u_y = -nu1 s y / E1,  u_z = -nu1 s z / E1,

which P2 elements hold exactly when the interface is an element boundary. So K u has no
force at any node off the two end faces (the interface nodes included, where a wrong
material shows first), the end faces carry -s B H and +s B H, and every cell's stress is
s e_x e_x. A bar of one material would need another u for the same stress.
"""

from __future__ import annotations

import numpy as np
import pytest
from skfem import MeshTet

from pipeline.core.errors import ConfigError
from pipeline.fem import Material, assemble_solid
from pipeline.fem.geometric import solid_modal_geometric_stiffness
from pipeline.fem.solid import solid_moments
from pipeline.fem.stress import solid_nodal_stress
from pipeline.meshing.mesh_data import MeshData

L, B, H, A = 0.4, 0.05, 0.03, 0.15  # m; the interface at x = A
STEEL = Material(210e9, 0.3, 7850.0)
LIGHT = Material(70e9, 0.1, 2700.0)  # nu / E as steel's
S = 1.0e6  # Pa


def _bar(materials=None, groups=None):
    sk = MeshTet.init_tensor(np.array([0.0, 0.05, 0.1, A, 0.2, 0.3, L]),
                             np.linspace(0.0, B, 3), np.linspace(0.0, H, 3))
    centroid_x = sk.p[0, sk.t].mean(axis=0)
    if groups is None:
        groups = {"NEAR": np.flatnonzero(centroid_x < A), "FAR": np.flatnonzero(centroid_x > A)}
    mesh = MeshData(sk.p.T, {"tetra": sk.t.T}, "solid", cell_groups=groups)
    mats = {"FAR": LIGHT} if materials is None else materials
    return assemble_solid(mesh, STEEL, "bar", mats), groups


def _exact(model, e2=LIGHT.E):
    x, y, z = model.nodes.T
    u = np.zeros(model.n_dof)
    u[model.node_dofs[:, 0]] = np.where(x <= A, S * x / STEEL.E,
                                        S * A / STEEL.E + S * (x - A) / e2)
    u[model.node_dofs[:, 1]] = -STEEL.nu * S * y / STEEL.E
    u[model.node_dofs[:, 2]] = -STEEL.nu * S * z / STEEL.E
    return u


def test_two_materials_in_series_hold_the_exact_state(caplog):
    with caplog.at_level("WARNING", logger="pipeline.fem.solid"):
        model, groups = _bar()
    # the near part takes the link's own material, and the log says so
    assert f"{groups['NEAR'].size} of {model.extras['cells'].shape[0]} cells are in none " \
        "of the element sets given materials (FAR)" in caplog.text
    f = (model.stiffness @ _exact(model))[model.node_dofs]  # (nodes, 3), N
    x = model.nodes[:, 0]
    inner = (x > 1e-12) & (x < L - 1e-12)
    scale = S * B * H
    assert np.abs(f[inner]).max() < 1e-9 * scale
    assert f[np.isclose(x, L), 0].sum() == pytest.approx(scale, rel=1e-10)
    assert f[np.isclose(x, 0.0), 0].sum() == pytest.approx(-scale, rel=1e-10)
    # a bar given one material has forces at the interface for this field
    one, _ = _bar(materials={})
    f1 = (one.stiffness @ _exact(one))[one.node_dofs]
    assert np.abs(f1[inner]).max() > 0.1 * scale
    # each cell's stress with its own material: s e_x e_x in both parts
    sigma = solid_nodal_stress(model, _exact(model)[:, None])[0]  # (nodes, 6) Voigt
    assert np.allclose(sigma[:, 0], S, rtol=1e-9)
    assert np.abs(sigma[:, 1:]).max() < 1e-9 * S


def test_mass_and_its_moments_weigh_each_cell_by_its_density():
    model, _ = _bar()
    m1, m2 = STEEL.rho * A * B * H, LIGHT.rho * (L - A) * B * H
    ux = np.zeros(model.n_dof)
    ux[model.node_dofs[:, 0]] = 1.0
    assert ux @ (model.mass @ ux) == pytest.approx(m1 + m2, rel=1e-12)
    C = solid_moments(model, np.zeros((model.n_dof, 0))).C
    assert C[3, 3] == pytest.approx(m1 + m2, rel=1e-12)
    x_c = (m1 * A / 2 + m2 * (A + L) / 2) / (m1 + m2)
    assert C[0, 3] / C[3, 3] == pytest.approx(x_c, rel=1e-12)
    # int rho x^2 dV, piecewise
    xx = STEEL.rho * B * H * A**3 / 3 + LIGHT.rho * B * H * (L**3 - A**3) / 3
    assert C[0, 0] == pytest.approx(xx, rel=1e-12)


def test_geometric_stiffness_follows_each_cells_stress():
    """The same uniform stress s in both models, made by the two-material field in the
    bar of two materials and by s x / E1 in a bar of steel alone: the geometric stiffness
    int s_ij dphi/dx_i dpsi/dx_j dV is a function of the stress only, so both agree."""
    model, _ = _bar()
    steel, _ = _bar(materials={})
    u1 = np.zeros(steel.n_dof)
    u1[steel.node_dofs[:, 0]] = S * steel.nodes[:, 0] / STEEL.E
    u1[steel.node_dofs[:, 1]] = -STEEL.nu * S * steel.nodes[:, 1] / STEEL.E
    u1[steel.node_dofs[:, 2]] = -STEEL.nu * S * steel.nodes[:, 2] / STEEL.E
    Phi = np.random.default_rng(3).standard_normal((model.n_dof, 4))
    KG = solid_modal_geometric_stiffness(model, _exact(model), Phi)
    KG1 = solid_modal_geometric_stiffness(steel, u1, Phi)
    assert np.allclose(KG, KG1, rtol=1e-9, atol=1e-9 * np.abs(KG1).max())
    # the two-material field in the steel bar is another stress: caught
    KG_wrong = solid_modal_geometric_stiffness(steel, _exact(steel), Phi)
    assert np.abs(KG_wrong - KG1).max() > 0.1 * np.abs(KG1).max()


def test_materials_of_unknown_or_clashing_sets_are_refused():
    with pytest.raises(ConfigError, match=r"materials\.EYE: the mesh has no element set 'EYE' "
                                          r"\(its element sets: \['FAR', 'NEAR'\]\)"):
        _bar(materials={"EYE": LIGHT})
    with pytest.raises(ConfigError, match="it has no element sets"):
        _bar(materials={"EYE": LIGHT}, groups={})
    _, groups = _bar()
    both = {**groups, "ALL": np.arange(groups["NEAR"].size + groups["FAR"].size)}
    with pytest.raises(ConfigError, match=r"materials\.ALL: element sets 'FAR' and 'ALL' "
                                          r"share \d+ cell\(s\)"):
        _bar(materials={"FAR": LIGHT, "ALL": STEEL}, groups=both)
    # the same material twice is no clash; a bad material names its set
    _bar(materials={"FAR": LIGHT, "ALL": LIGHT}, groups={"FAR": groups["FAR"],
                                                         "ALL": groups["FAR"]})
    with pytest.raises(ConfigError, match=r"materials\.FAR: material\.nu"):
        _bar(materials={"FAR": Material(70e9, 0.5, 2700.0)})


def test_element_set_names_match_regardless_of_case_as_in_abaqus():
    """Abaqus and CalculiX names are case-insensitive: a ``*SOLID SECTION, ELSET=far`` (or
    a spec's ``materials: {far: ...}``) means the file's ``*ELSET, ELSET=FAR``; an exact name
    wins, and two sets that differ only in case are not guessed between."""
    from pipeline.fem.material import assign_materials

    steel = Material(210e9, 0.3, 7850.0)
    groups = {"FAR": np.array([2, 3]), "NEAR": np.array([0, 1])}
    cm = assign_materials(steel, {"far": LIGHT}, groups, 4, "link 'bar'")
    assert cm.index.tolist() == [0, 0, 1, 1] and cm.names == ("material", "far")
    exact = assign_materials(steel, {"far": LIGHT}, {**groups, "far": np.array([0])}, 4, "x")
    assert exact.index.tolist() == [1, 0, 0, 0]
    with pytest.raises(ConfigError, match=r"materials\.Far: the mesh has element sets "
                                          r"\['FAR', 'far'\], which differ only in case"):
        assign_materials(steel, {"Far": LIGHT}, {**groups, "far": np.array([0])}, 4, "x")
