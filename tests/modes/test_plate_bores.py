"""End to end on a gmsh plate with two pin bores: mesh -> P2 solid -> interfaces -> modes."""

import numpy as np
import pytest

from pipeline.core.errors import ConfigError
from pipeline.fem.interfaces import InterfaceSpec, resolve_interfaces, tie_interfaces
from pipeline.modes import clamped_modes, frame_motion, lowest_modes

pytestmark = pytest.mark.gmsh

LENGTH, WIDTH, T, R = 0.2, 0.05, 0.01, 0.008


@pytest.fixture(scope="module")
def link():
    from pipeline.fem.material import Material
    from pipeline.fem.solid import assemble_solid
    from pipeline.meshing.geometry import SolidGeometry
    from pipeline.meshing.gmsh_build import build_mesh

    params = {"length": LENGTH, "width": WIDTH, "thickness": T,
              "bores": [{"name": "A", "center": [0.03, 0.0], "radius": R},
                        {"name": "B", "center": [0.17, 0.0], "radius": R}]}
    mesh = build_mesh(SolidGeometry("plate_with_bores", params, mesh_size=0.008), "link")
    model = assemble_solid(mesh, Material(E=70e9, nu=0.33, rho=2700.0), "link")
    return mesh, model


def _specs(kind_a, kind_b):
    from pipeline.meshing.selectors import CylinderSurface, PhysicalGroup

    return [InterfaceSpec("A", PhysicalGroup("bore_A"), [0.03, 0, 0], None, kind_a),
            InterfaceSpec("B", CylinderSurface((0.17, 0, 0), (0, 0, 1), R), [0.17, 0, 0],
                          None, kind_b)]


def test_selectors_find_the_bore_surfaces(link):
    mesh, model = link
    a, b = resolve_interfaces(model, _specs("rbe2", "rbe2"), mesh.groups)
    for itf, c in ((a, 0.03), (b, 0.17)):
        radius = np.linalg.norm(model.nodes[itf.nodes, :2] - [c, 0], axis=1)
        np.testing.assert_allclose(radius, R, rtol=1e-3)
        assert itf.nodes.size > 20


def test_selector_error_names_link_and_interface(link):
    from pipeline.meshing.selectors import CylinderSurface

    mesh, model = link
    spec = [InterfaceSpec("C", CylinderSurface((0.1, 0, 0), (0, 0, 1), 0.004), [0.1, 0, 0])]
    with pytest.raises(ConfigError, match=r"link 'link': interface 'C': selector "
                                          r"CylinderSurface.*matched no"):
        resolve_interfaces(model, spec, mesh.groups)


def test_pinned_link_modes_and_bore_stiffening(link):
    mesh, model = link
    rbe3 = tie_interfaces(model, resolve_interfaces(model, _specs("rbe2", "rbe3"), mesh.groups))
    rbe2 = tie_interfaces(model, resolve_interfaces(model, _specs("rbe2", "rbe2"), mesh.groups))
    # RBE3 at bore B adds no stiffness; RBE2 there does (free-free, shift below rigid modes)
    free = tie_interfaces(model, resolve_interfaces(model, _specs("rbe2", "rbe3")[:1],
                                                    mesh.groups))
    f = {}
    for key, tied in (("free", free), ("rbe3", rbe3), ("rbe2", rbe2)):
        lam, _ = lowest_modes(tied.stiffness, tied.mass, 10, sigma=-(2 * np.pi * 10) ** 2)
        f[key] = np.sqrt(np.abs(lam[6:])) / (2 * np.pi)
    np.testing.assert_allclose(f["rbe3"], f["free"], rtol=1e-10)
    assert np.all(f["rbe2"] >= f["free"] * (1 - 1e-10)) and (f["rbe2"] / f["free"]).max() > 1.01
    # Craig-Bampton clamped at A, constraint modes at B; phi/psi at B = identity block
    basis = clamped_modes(rbe2, "A", n_modes=4, craig_bampton=True)
    Phi = basis.shapes
    assert np.abs(Phi.T @ (model.mass @ Phi) - np.eye(10)).max() < 1e-8
    phi, psi = frame_motion(model, rbe2, basis, "B")
    motion = np.c_[phi, psi]  # (10, 6): the basis spans all 6 master motions of B
    assert np.linalg.matrix_rank(motion, tol=1e-8 * np.abs(motion).max()) == 6
