"""Point bodies attached to solids and beams: mass matrix and moments against the
closed-form rigid body (box + point body), modal-mass identity, free-free modes."""

from __future__ import annotations

import re

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from pipeline.core.errors import ConfigError
from pipeline.fem import Material, PointMass, add_point_masses, assemble_solid, mass_moments
from pipeline.fem.model import FemModel
from pipeline.meshing.mesh_data import MeshData

RHO = 7850.0
DIMS = np.array([0.4, 0.1, 0.06])
PAYLOAD_M = 3.5  # kg
PAYLOAD_P = np.array([0.45, 0.02, 0.08])  # m, outside the box
Q = np.linalg.qr(np.random.default_rng(7).standard_normal((3, 3)))[0]
PAYLOAD_J = Q @ np.diag([0.02, 0.03, 0.04]) @ Q.T  # kg m^2 about its centre, full tensor


@pytest.fixture(scope="module")
def box():
    from skfem import MeshTet

    m = MeshTet.init_tensor(*[np.linspace(0, d, n) for d, n in zip(DIMS, (6, 3, 2))])
    return assemble_solid(MeshData(m.p.T, {"tetra": m.t.T}, "solid"),
                          Material(210e9, 0.3, RHO), "box")


def rigid_fields(model) -> np.ndarray:
    """(n_dof, 6) unit translations and rotations about the origin (solid or beam)."""
    R = np.zeros((model.n_dof, 6))
    for a in range(3):
        R[model.node_dofs[:, a], a] = 1.0
        R[model.node_dofs[:, :3], 3 + a] = np.cross(np.eye(3)[a], model.nodes)
        if model.has_rotations:
            R[model.node_dofs[:, 3 + a], 3 + a] = 1.0
    return R


def rigid_mass_matrix(C: np.ndarray) -> np.ndarray:
    """6 x 6 mass matrix about the origin of a rigid body with moments C (4, 4)."""
    m, first, S = C[3, 3], C[:3, 3], C[:3, :3]
    sk = np.array([[0, -first[2], first[1]], [first[2], 0, -first[0]], [-first[1], first[0], 0]])
    out = np.zeros((6, 6))
    out[:3, :3] = m * np.eye(3)
    out[:3, 3:] = -sk
    out[3:, :3] = sk
    out[3:, 3:] = np.trace(S) * np.eye(3) - S
    return out


def closed_form_C(with_payload: bool) -> np.ndarray:
    m = RHO * DIMS.prod()
    c = DIMS / 2
    C = np.zeros((4, 4))
    C[:3, :3] = np.diag(m * DIMS**2 / 12) + m * np.outer(c, c)
    C[:3, 3] = C[3, :3] = m * c
    C[3, 3] = m
    if with_payload:
        p = np.append(PAYLOAD_P, 1.0)
        C += PAYLOAD_M * np.outer(p, p)
        C[:3, :3] += 0.5 * np.trace(PAYLOAD_J) * np.eye(3) - PAYLOAD_J
    return C


@pytest.mark.parametrize("radius", [None, 0.12])
def test_payload_on_solid_matches_closed_form_rigid_body(box, radius):
    payload = PointMass("payload", PAYLOAD_P, PAYLOAD_M, PAYLOAD_J, attach_radius=radius)
    model = add_point_masses(box, [payload], "link 'box'")
    ref = closed_form_C(True)
    C = mass_moments(model, np.zeros((model.n_dof, 0))).C
    np.testing.assert_allclose(C, ref, rtol=0, atol=1e-10 * np.abs(ref).max())
    R = rigid_fields(model)
    rigid = R.T @ model.mass @ R
    np.testing.assert_allclose(rigid, rigid_mass_matrix(ref), rtol=0, atol=1e-10 * np.abs(rigid).max())
    # The input model is untouched; the record is what mass_moments consumes.
    np.testing.assert_allclose(R.T @ box.mass @ R, rigid_mass_matrix(closed_form_C(False)),
                               atol=1e-10 * np.abs(rigid).max())
    (rec,) = model.extras["point_masses"]
    assert rec["name"] == "payload" and rec["operator"].shape == (6, model.n_dof)


def test_modal_mass_identity_and_six_rigid_modes(box):
    payload = PointMass("payload", PAYLOAD_P, PAYLOAD_M, PAYLOAD_J)
    particle = PointMass("bolt", np.array([0.1, 0.05, 0.03]), 0.2)
    model = add_point_masses(box, [payload, particle], "link 'box'")
    U = np.random.default_rng(5).standard_normal((model.n_dof, 4))
    mm = mass_moments(model, U)
    gram = U.T @ model.mass @ U
    np.testing.assert_allclose(np.einsum("abkk->ab", mm.Cpp), gram, atol=1e-12 * np.abs(gram).max())
    assert abs(model.mass - model.mass.T).max() == 0.0
    w2 = sla.eigsh(model.stiffness, 8, model.mass, sigma=-1.0, return_eigenvectors=False)
    w2 = np.sort(w2)
    print(f"\nfree-free eigenvalues (rad/s)^2: {w2}")
    assert np.all(np.abs(w2[:6]) < 1e-6 * w2[6]) and w2[6] > 1e4


def test_point_mass_on_beam_node():
    """A 6-DOF node carries the body rigidly: rigid mass matrix = closed form."""
    nodes = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    model = FemModel("b", "beam", nodes, np.arange(12).reshape(2, 6),
                     sp.csr_matrix((12, 12)), sp.csr_matrix((12, 12)))
    p = np.array([1.1, 0.3, -0.2])
    out = add_point_masses(model, [PointMass("hook", p, PAYLOAD_M, PAYLOAD_J)], "link 'b'")
    C = np.zeros((4, 4))
    ph = np.append(p, 1.0)
    C += PAYLOAD_M * np.outer(ph, ph)
    C[:3, :3] += 0.5 * np.trace(PAYLOAD_J) * np.eye(3) - PAYLOAD_J
    R = rigid_fields(out)
    np.testing.assert_allclose(R.T @ out.mass @ R, rigid_mass_matrix(C), atol=1e-12)
    assert out.mass[:6].nnz == 0  # attached to the nearest node only
    np.testing.assert_allclose(_point_C(out), C, atol=1e-12)


def _point_C(model):
    """C of the recorded point body (the beam kernel needs section data this model lacks)."""
    from pipeline.fem.moments import point_mass_moments

    (rec,) = model.extras["point_masses"]
    return point_mass_moments(rec["mass"], rec["second_moment"], rec["position"],
                              rec["operator"], np.zeros((model.n_dof, 0))).C


@pytest.mark.parametrize("kwargs, field", [
    ({"mass": 0.0}, "mass: expected a finite value > 0"),
    ({"mass": -2.0}, "mass: expected a finite value > 0"),
    ({"inertia": np.array([[1.0, 0.1, 0], [0, 1, 0], [0, 0, 1]])}, "inertia: expected a symmetric"),
    ({"inertia": np.diag([1.0, 1.0, -0.1])}, "inertia: expected a positive semi-definite"),
    ({"inertia": np.diag([1.0, 1.0, 3.0])}, "inertia: .* I1 \\+ I2 >= I3"),
    ({"inertia": np.eye(2)}, "inertia: expected shape"),
    ({"position": [0.0, np.nan, 0.0]}, "position: expected finite"),
    ({"attach_radius": 1e-4}, "attach_radius: expected a radius enclosing at least 4"),
    ({"attach_radius": -1.0}, "attach_radius: expected a finite value > 0"),
])
def test_point_mass_errors_name_link_body_and_field(box, kwargs, field):
    spec = {"name": "payload", "position": np.array([0.21, 0.05, 0.03]), "mass": 1.0, "inertia": None}
    spec.update(kwargs)
    with pytest.raises(ConfigError, match=f"^link 'box': point mass 'payload': {field}"):
        add_point_masses(box, [PointMass(**spec)], "link 'box'")


def test_a_far_point_body_is_fitted_about_the_nodes_and_said(box, caplog):
    """A payload 60 m from a 0.4 m box (a typo, or a very long rigid arm) moves as the box's
    rigid fit carried out to it: its mass moments are the closed-form rigid body's. The fit
    about the far point itself lost rank at round-off (lever 60 m over node spacings of
    centimetres) and was refused as 'a degenerate node set'; the distance is now said."""
    far = np.array([60.0, 0.02, 0.08])
    with caplog.at_level("WARNING"):
        out = add_point_masses(box, [PointMass("payload", far, PAYLOAD_M)], "link 'box'")
    assert re.search(r"link 'box': point mass 'payload' at \[60.0, 0.02, 0.08\] is 59.6 m from "
                     r"the nearest FE node, 149 times the link's size \(0.4 m\)", caplog.text)
    C = mass_moments(out, np.zeros((out.n_dof, 0))).C
    ref = closed_form_C(False) + PAYLOAD_M * np.outer(np.append(far, 1.0), np.append(far, 1.0))
    np.testing.assert_allclose(C, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    caplog.clear()
    with caplog.at_level("WARNING"):  # the shipped payload, 5 cm off the box: silent
        add_point_masses(box, [PointMass("payload", PAYLOAD_P, PAYLOAD_M)], "link 'box'")
    assert "nearest FE node" not in caplog.text


@pytest.mark.parametrize("distance", [0.0, 1.0, 1e3, 1e4])
def test_rigid_fit_reads_a_rigid_motion_at_any_point(distance):
    """G u of a rigid motion u = t + theta x (x - p) of four nodes 1 cm apart is [t, theta]
    to round-off, for a point p on them or 10 km away; three collinear nodes are
    refused wherever p is."""
    from pipeline.fem.rigid_fit import rigid_fit_operator

    rng = np.random.default_rng(3)
    x = np.array([[0.0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]) + 5.0
    p = x[0] + distance * np.array([0.6, -0.8, 0.0])
    t, theta = rng.standard_normal(3), 1e-3 * rng.standard_normal(3)
    u = (t + np.cross(theta, x - p)).ravel()
    G = rigid_fit_operator(x, np.arange(12).reshape(4, 3), 12, p)
    np.testing.assert_allclose(G @ u, np.concatenate([t, theta]), rtol=0,
                               atol=1e-12 * max(1.0, distance))
    with pytest.raises(ConfigError, match="at least 3 non-collinear nodes"):
        rigid_fit_operator(x[:3] * [1, 0, 0], np.arange(9).reshape(3, 3), 9, p)
