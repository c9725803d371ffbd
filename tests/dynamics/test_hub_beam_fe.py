"""Linearised vibration of a flexible cantilever on a rigid hub with a torsional spring
vs the full (unreduced) beam FE model of the same structure.

Structure (ground axes = hub axes at q = 0, SI units):

* a rigid hub turns about the ground z axis through the pivot O = (0, 0, 0); polar
  inertia ``J_HUB`` about that axis, torsional spring ``K_T`` to ground;
* a uniform straight beam (steel strip, ``Iz`` for bending in the x-y plane, ``Iy = 9 Iz``
  out of plane, so no two clamped modes are degenerate) of length ``L`` is clamped to
  the hub at the radius ``R``: its root sits at (R, 0, 0), it points along +x;
* no gravity, equilibrium q = 0, no prestress.

Multibody model: hub = rigid link on a revolute joint (z) to ground with a
:class:`JointSpringDamper`; beam = link reduced through the normal chain (spec -> gmsh
line mesh -> scikit-fem Hermite beam -> n modes clamped at the ``root`` interface ->
invariants), fixed to the hub marker ``mount`` = translation (R, 0, 0); linearised with
:func:`vibration_modes`.

Reference: the same beam assembled directly with :func:`assemble_beam` on a mesh built
here (uniform, from x = R to R + L, checked node for node against the reduced link), all
FE DOFs kept. The hub is one extra DOF theta (rotation about z); the root node is tied to
it by the rigid-body kinematics of a rotation about O: ``u_root = theta e_z x (R, 0, 0) =
(0, R theta, 0)``, ``rot_root = (0, 0, theta)``, i.e. q_FE = T q_red with the root's six
rows of T given by that map. Then ``K = T^T K_beam T + K_T e_theta e_theta^T``,
``M = T^T M_beam T + J_HUB e_theta e_theta^T``, solved with ``scipy.linalg.eigh``.

Because the clamped modes and the rigid hub rotation span a subspace of exactly this FE
space, and the invariants come from the same mass operator, the multibody frequencies
are Rayleigh-Ritz upper bounds of the FE ones, non-increasing as modes are added (nested
subspaces). The in-plane (x-y) and out-of-plane motions decouple exactly, so both models
are compared on their in-plane modes (tip moves along y rather than z).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from pipeline.dynamics import System
from pipeline.dynamics.bodies import body_from_reduced, link_from_reduced
from pipeline.dynamics.forces import JointSpringDamper
from pipeline.dynamics.linearize import marker_motion, vibration_modes
from pipeline.dynamics.system import BodyMass
from pipeline.fem.beam import assemble_beam
from pipeline.fem.section import BeamSection
from pipeline.kinematics import Joint, build_mechanism, rigid_link
from pipeline.kinematics.rotations import translation
from pipeline.meshing.mesh_data import MeshData

pytestmark = pytest.mark.gmsh

#: Steel strip: L m, E Pa, nu, rho kg/m^3, A m^2, Iz (in-plane) m^4, element size m.
L, E, NU, RHO, A, IZ, H = 2.0, 2.1e11, 0.3, 7850.0, 1.0e-3, 2.0e-7, 0.05
IY, J_T = 9.0 * IZ, 4.0 * IZ
#: Hub: pivot-to-root radius m, polar inertia about the pivot kg m^2, spring N m/rad.
R, J_HUB, K_T = 0.3, 5.0, 5.0e4
N_IN_PLANE = 4

HUB_BEAM_YAML = f"""\
name: beam
geometry:
  type: beam
  points: [[0, 0, 0], [{L}, 0, 0]]
  vertex_names: [root, tip]
  element_size: {H}
material: {{E: {E}, nu: {NU}, rho: {RHO}}}
sections:
  - {{A: {A}, Iy: {IY}, Iz: {IZ}, J: {J_T}, members: [0]}}
interfaces:
  - name: root
    selector: {{type: nearest, point: [0, 0, 0]}}
    z_axis: [0, 0, 1]
  - name: tip
    selector: {{type: nearest, point: [{L}, 0, 0]}}
    z_axis: [0, 0, 1]
reference: root
modes: {{count: {{m}}}}
"""


def reduced_beam(folder, n_modes: int):
    """ReducedLink of the strip through the link-spec route (gmsh -> skfem -> modes)."""
    from pipeline.invariants.reduce import reduce_link
    from pipeline.workflow.link_build import link_request
    from pipeline.workflow.link_spec import load_link_spec

    path = folder / f"beam_{n_modes}.yaml"
    path.write_text(HUB_BEAM_YAML.replace("{m}", str(n_modes)))
    request, _ = link_request(load_link_spec(path), folder)
    return reduce_link(request)


def hub_beam_system(reduced) -> System:
    """ground -revolute(z, spring K_T)- hub -fixed at (R, 0, 0)- beam (reduced)."""
    hub = rigid_link("hub", {"mount": translation([R, 0.0, 0.0])})
    mech = build_mechanism(
        [rigid_link("ground"), hub, link_from_reduced(reduced)],
        [Joint("pivot", "revolute", "ground", "body", "hub", "body"),
         Joint("mount", "fixed", "hub", "mount", "beam", "body")])
    # Hub mass is irrelevant (pivot fixed); only its inertia about z enters.
    hub_mass = BodyMass.rigid(10.0, [0.0, 0.0, 0.0], np.diag([1.0, 1.0, J_HUB]))
    return System(mech, {"hub": hub_mass, "beam": body_from_reduced(reduced)},
                  [0.0, 0.0, 0.0],
                  forces=[JointSpringDamper("k", "pivot.theta", stiffness=K_T)])


def multibody_in_plane(reduced) -> np.ndarray:
    """Lowest in-plane natural frequencies (rad/s) of the hub + reduced-beam model."""
    system = hub_beam_system(reduced)
    modes = vibration_modes(system, np.zeros(system.mechanism.n))
    tip = marker_motion(system, modes, "beam", "tip")
    return modes.omega[np.abs(tip[1]) > np.abs(tip[2])]


def fe_mesh() -> MeshData:
    """Uniform beam mesh in hub axes: root at x = R, tip at x = R + L."""
    n_el = round(L / H)
    x = R + np.linspace(0.0, L, n_el + 1)
    points = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    cells = np.column_stack([np.arange(n_el), np.arange(1, n_el + 1)])
    return MeshData(points=points, cells={"line": cells}, kind="beam")


def full_fe_in_plane() -> tuple[np.ndarray, MeshData]:
    """Lowest in-plane natural frequencies (rad/s) of the full FE hub + beam, and its mesh."""
    mesh = fe_mesh()
    section = BeamSection(A, IY, IZ, J_T, E, E / (2 * (1 + NU)), RHO)
    model = assemble_beam(mesh, section, "beam")
    root = int(np.argmin(mesh.points[:, 0]))
    tip = int(np.argmax(mesh.points[:, 0]))
    root_dofs = model.node_dofs[root]
    free = np.setdiff1d(np.arange(model.n_dof), root_dofs)
    # q_FE = T [theta, q_free]: root rows follow the rigid rotation about z through O.
    T = np.zeros((model.n_dof, 1 + free.size))
    T[root_dofs[1], 0] = R    # u_y = theta * R   (e_z x (R, 0, 0) = (0, R, 0))
    T[root_dofs[5], 0] = 1.0  # r_z = theta
    T[free, 1 + np.arange(free.size)] = 1.0
    K = T.T @ model.stiffness.toarray() @ T
    M = T.T @ model.mass.toarray() @ T
    K[0, 0] += K_T
    M[0, 0] += J_HUB
    lam, V = sla.eigh(K, M)
    shapes = T @ V
    uy, uz = shapes[model.node_dofs[tip, 1]], shapes[model.node_dofs[tip, 2]]
    return np.sqrt(lam[np.abs(uy) > np.abs(uz)]), mesh


def test_hub_beam_reduced_frequencies_converge_from_above_to_full_fe(tmp_path):
    ref, mesh = full_fe_in_plane()
    ref = ref[:N_IN_PLANE]
    # Rayleigh bound from the rigid rotation of hub + beam about z (section rotary inertia
    # about z is rho Iz per length)
    j_total = J_HUB + RHO * A * L * (R**2 + R * L + L**2 / 3) + RHO * IZ * L
    assert ref[0] < np.sqrt(K_T / j_total)
    print(f"\nfull FE in-plane omega [rad/s] {np.round(ref, 4)}")
    rel = {}
    for n in (1, 2, 4, 6, 12):
        reduced = reduced_beam(tmp_path, n)
        nodes = reduced.nodes[np.argsort(reduced.nodes[:, 0])] + [R, 0.0, 0.0]
        np.testing.assert_allclose(nodes, mesh.points, atol=1e-9)  # same mesh
        f = multibody_in_plane(reduced)[:N_IN_PLANE]
        rel[n] = np.full(N_IN_PLANE, np.nan)
        rel[n][:f.size] = f / ref[:f.size] - 1
        print(f"n = {n:2d} modes: omega {np.round(f, 4)} rel {np.array2string(rel[n], precision=3)}")
        # Rayleigh-Ritz: upper bounds of the full FE frequencies
        assert np.all(rel[n][:f.size] > -1e-7)
    for a, b in zip((1, 2, 4, 6), (2, 4, 6, 12)):  # nested subspaces: non-increasing
        both = ~np.isnan(rel[a])
        assert np.all(rel[b][both] <= rel[a][both] + 1e-7)
    # clamped modes 1-4 are in-plane 1, out-of-plane 1, in-plane 2, 3: with n >= 4 the
    # lowest 4 in-plane frequencies (hub + 3 bending) are all present and within 1 %
    for n in (4, 6, 12):
        assert np.all(np.abs(rel[n]) < 1e-2)
    assert np.all(np.abs(rel[12]) < 1e-4)
