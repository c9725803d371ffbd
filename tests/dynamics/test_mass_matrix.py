"""Mass matrix against closed forms: rigid double pendulum, modal block, downstream terms."""

from __future__ import annotations

import numpy as np
from eom_models import flexible_double_pendulum

from pipeline.dynamics import BodyMass, System
from pipeline.dynamics.mass_matrix import mass_matrix
from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
from pipeline.kinematics.rotations import translation


def test_rigid_double_pendulum_closed_form():
    L1, m1, c1, I1, m2, c2, I2 = 1.2, 2.0, 0.5, 0.3, 1.5, 0.4, 0.1
    mech = build_mechanism(
        [rigid_link("ground"), rigid_link("a", {"P": translation([L1, 0, 0])}), rigid_link("b")],
        [Joint("j1", "revolute", "ground", "body", "a", "body"),
         Joint("j2", "revolute", "a", "P", "b", "body")])
    s = System(mech, {"a": BodyMass.rigid(m1, [c1, 0, 0], np.diag([0.2, 0.2, I1])),
                      "b": BodyMass.rigid(m2, [c2, 0, 0], np.diag([0.1, 0.1, I2]))})
    for q2 in (0.0, 0.7, 2.5):
        q = np.array([0.3, q2])
        M = mass_matrix(s, evaluate_tree(mech, q), q)
        k = m2 * L1 * c2 * np.cos(q2)
        M22 = I2 + m2 * c2 ** 2
        ref = np.array([[I1 + m1 * c1 ** 2 + M22 + m2 * L1 ** 2 + 2 * k, M22 + k],
                        [M22 + k, M22]])
        assert np.allclose(M, ref, rtol=1e-14, atol=1e-14)


def test_modal_block_of_a_grounded_link_is_the_modal_mass():
    full = flexible_double_pendulum().system
    s = System(full.mechanism, {"link1": full.bodies["link1"]}, full.gravity)  # link2 massless
    q = np.random.default_rng(0).standard_normal(s.mechanism.n)
    M = mass_matrix(s, evaluate_tree(s.mechanism, q), q)
    idx = s.mechanism.modal_index[1]  # link1 hangs on the ground joint: rigid rotation
    Cpp = s.bodies["link1"].Cpp
    assert np.allclose(M[np.ix_(idx, idx)], np.trace(Cpp, axis1=2, axis2=3), rtol=1e-13)


def test_downstream_modal_coupling_is_kept():
    """link1's modes move link2 (through S(eta) at its tip): M couples them."""
    s = flexible_double_pendulum().system
    q = np.zeros(s.mechanism.n)
    M = mass_matrix(s, evaluate_tree(s.mechanism, q), q)
    e1 = s.mechanism.modal_index[1]
    e2 = s.mechanism.modal_index[2]
    j2 = s.mechanism.index("j2.theta")
    assert np.abs(M[e1, j2]).min() > 1e-4  # link2's rotation with link1's modes
    assert np.abs(M[np.ix_(e1, e2)]).max() > 1e-5
    # dropping link2's mass removes exactly these couplings
    s1 = System(s.mechanism, {"link1": s.bodies["link1"]}, s.gravity)
    M1 = mass_matrix(s1, evaluate_tree(s.mechanism, q), q)
    assert np.all(M1[e1, j2] == 0.0) and np.all(M1[np.ix_(e1, e2)] == 0.0)


def test_compiled_inertia_terms_equal_the_numpy_reference():
    """The compiled inertia terms against the numpy oracle (flexible links upstream of
    others, second-order first moments, random states)."""
    from eom_models import flexible_four_bar

    for s in (flexible_double_pendulum(n_modes=3).system, flexible_four_bar(n_modes=2).system,
              flexible_double_pendulum(n_modes=3, second_order=True).system):
        _compiled_equals_reference(s, np.random.default_rng(4), 3, 1.0)


def _compiled_equals_reference(s, rng, states: int, spread: float) -> None:
    """M, h, the gravity force and potential, the kinetic energy and every body's J(eta),
    N(eta), compiled (subtree sums) against the numpy link-by-link oracle at random states
    (1e-13)."""
    import inertia_numpy as ref

    from pipeline.dynamics.compiled import link_terms
    from pipeline.dynamics.energy import kinetic_energy
    from pipeline.dynamics.equations import equation_terms
    from pipeline.dynamics.gravity import gravity_potential

    def close(a, b, what):
        assert np.abs(np.asarray(a) - b).max() <= 1e-13 * np.abs(b).max(), what

    for _ in range(states):
        q, qd = rng.uniform(-spread, spread, s.mechanism.n), rng.normal(size=s.mechanism.n)
        fast = equation_terms(s, q, qd, 0.2)
        tree = fast.tree
        close(fast.M, ref.mass_matrix(s, tree, q), "M")
        close(fast.h, ref.velocity_terms(s, tree, q, qd), "h")
        close(fast.Q_gravity, ref.gravity_force(s, tree, q), "Q_gravity")
        close(gravity_potential(s, tree, q), ref.gravity_potential(s, tree, q), "V")
        close(kinetic_energy(s, tree, q, qd), ref.kinetic_energy(s, tree, q, qd), "T")
        for _, body, idx in s.mass_links:
            for a, b in zip(link_terms(body, q[idx]), ref.link_terms(body, q[idx]),
                            strict=True):
                if b.size:
                    close(a, b, "J, N")
        assert np.abs(fast.M - fast.M.T).max() <= 1e-15 * np.abs(fast.M).max()


def _branched_tree():
    """A flexible trunk carrying two branches at two flexible frames: a flexible link on
    a revolute, and a massless rigid link on a universal joint carrying a rigid link on a
    prismatic; a spherical joint at the ground (the composite sums' hard cases: several
    children of one flexible link, multi-motion steps, a massless link between massive
    ones)."""
    from eom_models import cloud, frame_modes

    from pipeline.kinematics import flexible_link
    from pipeline.kinematics.rotations import homogeneous, rot_x

    rng = np.random.default_rng(7)
    m = 3
    trunk, branch = cloud(rng, 1.0, m, mass=2.0), cloud(rng, 0.7, 2, mass=1.0)
    links = [rigid_link("ground"),
             flexible_link("trunk", {"B": (translation([1.0, 0, 0]), *frame_modes(rng, m)),
                                     "D": (homogeneous(rot_x(0.4), [0.5, 0.1, 0]), *frame_modes(rng, m))}),
             flexible_link("leaf", {"E": (translation([0.7, 0, 0]), *frame_modes(rng, 2))}),
             rigid_link("hub", {"F": translation([0.2, 0, 0.1])}),
             rigid_link("tip")]
    joints = [Joint("S", "spherical", "ground", "body", "trunk", "body"),
              Joint("R", "revolute", "trunk", "B", "leaf", "body"),
              Joint("U", "universal", "trunk", "D", "hub", "body"),
              Joint("P", "prismatic", "hub", "F", "tip", "body")]
    bodies = {"trunk": trunk.body(np.eye(m)), "leaf": branch.body(np.eye(2)),
              "tip": BodyMass.rigid(0.8, [0.1, 0.05, 0.0], np.diag([0.01, 0.02, 0.015]))}
    return System(build_mechanism(links, joints), bodies, gravity=[0.0, -9.81, 0.0])


def test_composite_sums_on_a_branched_tree_equal_the_link_by_link_sums():
    """The compiled kernel's subtree sums against the numpy link-by-link sums on a tree
    with branches at a flexible link's frames, multi-motion joints and a massless link."""
    _compiled_equals_reference(_branched_tree(), np.random.default_rng(11), 4, 0.8)
