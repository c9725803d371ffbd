"""Geometric-stiffening invariants of a reduced link: inertia and frame-force load cases.

Every inertia load of a moving link -- translational and angular acceleration, spin,
gravity -- is a body force linear in the body coordinates, a combination of twelve unit
fields rho xb_j e_k (xb = [x, y, z, 1] from the body-frame origin, body axes;
:func:`pipeline.fem.geometric.inertia_loads`). Each is solved once on the FE model
clamped at the reference interface -- the same clamp as the modes -- and its geometric
stiffness projected on the modes:

    K_jk = Phi^T K_sigma(N_jk) Phi    (m, m) per case.

By virtual work with the Green-Lagrange strain, the unit case's prestress does through the
nonlinear strain the work that its body force does through the second-order displacement
u2 of the mass, so K_jk are also the link's **second-order mass moments**,
``int rho xb_j u2_k dV = -eta^T K_jk eta / 2``
(:meth:`pipeline.invariants.reduced_link.ReducedLink.second_order_moments`). They enter the
mass distribution of the equations of motion (:mod:`pipeline.dynamics.mass_matrix`), so
that the link's own motion stiffens it with the energy that goes with it. The six unit
centrifugal cases (:data:`pipeline.fem.geometric.CENTRIFUGAL_CASES`) are combinations of
them (:func:`centrifugal_from_inertia`), kept in the artifact for inspection.
:func:`frame_force_stiffness` does the same for unit forces at the link's frames
(applied loads at its pins and markers). Beam links and P2 solids.

The force cases double as the frames' **second-order kinematics**
(:meth:`pipeline.invariants.reduced_link.ReducedLink.frame_hessians`). A unit force along
body axis k at frame f does, through the second-order displacement of its point of
application, the work that its prestress does through the nonlinear strain (virtual work
with the Green-Lagrange strain; for a bar, the chord shortens by ``int w'^2 dx / 2``), so
the frame's translation to second order is

    r_f,k(eta) = r_f,k(0) + phi_f,k eta - eta^T K_F,f,k eta / 2.

A force acting at the frame -- applied, or transmitted by a joint whose reaction the
loop closure carries -- then stiffens the modes by F_k K_F,f,k through the frame's own
kinematics: conservatively, and with no force element in between.
"""

from __future__ import annotations

import numpy as np

from pipeline.core.progress import report
from pipeline.fem.geometric import (
    beam_axial_forces,
    beam_geometric_stiffness,
    centrifugal_fields,
    inertia_loads,
    solid_modal_geometric_stiffness,
)
from pipeline.fem.interfaces import TiedModel
from pipeline.fem.model import FemModel
from pipeline.modes.basis import ModalBasis
from pipeline.modes.clamp import ClampedProblem


def inertia_stiffness(model: FemModel, tied: TiedModel, basis: ModalBasis,
                      body_pose: np.ndarray, problem: ClampedProblem | None = None
                      ) -> np.ndarray:
    """(4, 3, m, m) geometric stiffness of the twelve unit inertia cases
    (:func:`pipeline.fem.geometric.inertia_loads`: body force rho xb_j e_k, xb = [x, y, z,
    1] in body axes), the link clamped as its modes are.

    By virtual work they are also minus the second derivatives of the link's second-order
    mass moments: with u2 the second-order displacement of its mass,
    ``int rho xb_j u2_k dV = -eta^T K_jk eta / 2`` (for a bar: every section pulled back
    by the shortening inboard of it). Held as
    :meth:`pipeline.invariants.reduced_link.ReducedLink.second_order_moments`, they enter
    the link's mass distribution, so that its accelerations, spin and gravity stiffen or
    soften its modes with the kinetic and potential energy that go with it. Any inertia
    field is their combination (the centrifugal cases: :func:`centrifugal_from_inertia`).
    N m per unit field per modal unit^2.
    """
    loads = inertia_loads(model, body_pose[:3, 3], body_pose[:3, :3])
    out = _projected(model, tied, basis, loads.reshape(12, -1), "inertia", problem)
    return out.reshape(4, 3, *out.shape[1:])


def centrifugal_from_inertia(K_inertia: np.ndarray) -> np.ndarray:
    """(6, m, m) the unit centrifugal cases' geometric stiffness (:data:`CENTRIFUGAL_CASES`,
    body axes) from the (4, 3, m, m) inertia cases: the centrifugal field B_c xb is
    sum_jk B_c[k, j] xb_j e_k, and the geometric stiffness is linear in the load."""
    return np.einsum("ckj,jkab->cab", centrifugal_fields(), K_inertia[:3])


def frame_force_stiffness(model: FemModel, tied: TiedModel, basis: ModalBasis,
                          body_pose: np.ndarray, frames,
                          problem: ClampedProblem | None = None) -> np.ndarray:
    """(F, 3, m, m) geometric stiffness per unit force (N) along each body axis at each
    of ``frames`` (Interface objects in the artifact's frame order), the force applied
    through the frame's own motion operator (the work-conjugate load: a beam node with
    its moment arm, a solid interface's rigid fit): a rod pulled at its far pin, a boom
    carrying a load at its tip. N m per N per modal unit^2."""
    from pipeline.fem.interfaces import interface_operator

    R = body_pose[:3, :3]
    loads = []
    for itf in frames:
        G = interface_operator(model, itf)[:3]  # translation of the frame's point
        loads += [np.asarray(G.T @ R[:, k]).ravel() for k in range(3)]
    out = _projected(model, tied, basis, np.array(loads), "frame force", problem)
    m = out.shape[-1]
    return out.reshape(len(frames), 3, m, m)


def _projected(model, tied, basis, loads, what: str, problem=None) -> np.ndarray:
    """Phi^T K_sigma Phi of each load case (rows of ``loads``, full DOFs), solved clamped
    at the modes' reference (in ``problem``, whose factorisation is reused)."""
    if problem is None:
        problem = ClampedProblem(tied, basis.reference, basis.settings.get("chord"))
    space, lu = problem.space, problem.factor()
    expand = tied.transform @ space.L  # clamped coordinates -> full DOFs
    Phi = basis.shapes
    out = np.empty((len(loads), Phi.shape[1], Phi.shape[1]))
    # all cases in one solve: a factor's pass serves every right-hand side
    U = expand @ np.asarray(lu.solve(np.asarray(expand.T @ np.asarray(loads).T)))
    for c, u in enumerate(U.T):
        report(f"geometric stiffness, {what} case {c + 1} of {len(loads)}")
        if model.kind == "beam":
            KG = Phi.T @ (beam_geometric_stiffness(model, beam_axial_forces(model, u)) @ Phi)
        else:
            KG = solid_modal_geometric_stiffness(model, u, Phi)
        out[c] = 0.5 * (KG + KG.T)
    return out

