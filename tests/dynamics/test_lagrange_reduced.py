"""Reduced Lagrange check on the flexible closed loop: with T_r(q_I, q'_I) = T(q(q_I), q')
(q by position analysis, q' by velocity analysis of the kinematics layer, T hand-coded),
B^T (M q'' + h) with q'' = B q''_I + c equals d/dt dT_r/dq'_I - dT_r/dq_I."""

from __future__ import annotations

import numpy as np
from eom_models import flexible_four_bar, kinetic

from pipeline.dynamics.equations import equation_terms
from pipeline.dynamics.partition import complete_position, partition_system, reduced_state
from pipeline.kinematics import assemble, closure, solve_velocity

H = 1e-5


def test_reduced_equations_match_fd_of_reduced_kinetic_energy():
    model = flexible_four_bar(n_modes=2)
    s = model.system
    mech = s.mechanism
    q0 = mech.q_initial.copy()
    q0[mech.modal_coordinates] = [0.05, -0.03]
    q0 = assemble(mech, q0).q
    part = partition_system(s, q0)
    I = part.independent

    def full(qI, qdI):
        q = complete_position(s, part, qI, 0.0, q0)[0]
        v = np.zeros(mech.n)
        v[I] = qdI
        return q, solve_velocity(closure(mech, q).J, part.kin, v)

    def Tr(qI, qdI):
        return kinetic(model.positions, model.masses, *full(qI, qdI))

    def p(qI, qdI):
        return np.array([(Tr(qI, qdI + e) - Tr(qI, qdI - e)) / 2 for e in np.eye(I.size)])

    rng = np.random.default_rng(4)
    qI, qdI, qddI = q0[I], rng.standard_normal(I.size), rng.standard_normal(I.size)
    ref = ((p(qI + H * qdI, qdI) - p(qI - H * qdI, qdI)) / (2 * H)
           + p(qI, qdI + qddI) - p(qI, qdI)
           - np.array([(Tr(qI + H * e, qdI) - Tr(qI - H * e, qdI)) / (2 * H)
                       for e in np.eye(I.size)]))
    # pipeline: B and c from the partition; q'' = B q''_I + c with the chosen q''_I
    st = reduced_state(s, part, qI, qdI, 0.0, q0)
    qdd = st.qdd + st.B @ (qddI - st.qdd_I)
    terms = equation_terms(s, st.q, st.qd, 0.0)
    ours = st.B.T @ (terms.M @ qdd + terms.h)
    assert np.abs(ours - ref).max() < 1e-6 * np.abs(ref).max(), (ours, ref)
