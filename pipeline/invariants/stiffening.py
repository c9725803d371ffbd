"""Geometric-stiffening invariants of a reduced link (centrifugal load cases).

A link spinning with body angular velocity w carries the centrifugal prestress of the
body force ``rho (|w|^2 1 - w w^T) r`` (r from the body-frame origin). Linear in the six
products p_c(w) (:data:`pipeline.fem.geometric.CENTRIFUGAL_CASES`), it is solved once per
unit case on the FE model clamped at the reference interface -- the same clamp as the
modes -- and its geometric stiffness is projected on the modes:

    K_G,c = Phi^T K_sigma(N_c) Phi    (m, m) per case, N m per (rad/s)^2,

so that in motion the modal equations gain ``sum_c p_c(w) K_G,c eta`` (the stiffening the
linear modal kinematics leaves out: the centrifugal softening is already in C''_ab).
:func:`frame_force_stiffness` does the same for unit forces at the link's frames (applied
loads at its pins and markers). Beam links and P2 solids.

The force cases double as the frames' **second-order kinematics**
(:meth:`pipeline.invariants.reduced_link.ReducedLink.frame_hessians`). A unit force along body axis k at frame f does, through the
second-order displacement of its point of application, the work that its prestress does
through the nonlinear strain (virtual work with the Green-Lagrange strain; for a bar,
the chord shortens by ``int w'^2 dx / 2``), so the frame's translation to second order is

    r_f,k(eta) = r_f,k(0) + phi_f,k eta - eta^T K_F,f,k eta / 2.

A force acting at the frame -- applied, or transmitted by a joint whose reaction the
loop closure carries -- then stiffens the modes by F_k K_F,f,k through the frame's own
kinematics: conservatively, and with no force element in between.
"""

from __future__ import annotations

import numpy as np

from pipeline.core.progress import report
from pipeline.fem.geometric import (
    CENTRIFUGAL_CASES,
    acceleration_loads,
    beam_axial_forces,
    beam_geometric_stiffness,
    centrifugal_loads,
    solid_centrifugal_loads,
    solid_modal_geometric_stiffness,
)
from pipeline.fem.interfaces import TiedModel
from pipeline.fem.model import FemModel
from pipeline.modes.basis import ModalBasis
from pipeline.modes.clamp import ClampedProblem


def centrifugal_stiffness(model: FemModel, tied: TiedModel, basis: ModalBasis,
                          body_pose: np.ndarray, problem: ClampedProblem | None = None
                          ) -> tuple[np.ndarray, dict]:
    """(6, m, m) K_G,c of the unit centrifugal cases (w in body axes) and a summary.

    Parameters
    ----------
    model, tied : the link's FE model (beam or P2 solid) and its tied interfaces.
    basis : its clamped modes (``basis.reference`` is the clamp of the load cases).
    body_pose : (4, 4) body frame in the link frame (origin = spin point, axes = the
        axes w is given in).
    problem : the modes' clamped problem, to reuse its factorisation (built if None).

    Returns
    -------
    K_G : (6, m, m) symmetric, N m per (rad/s)^2 per modal unit^2.
    info : {"cases": names} for the artifact's provenance.
    """
    if model.kind == "beam":
        loads = centrifugal_loads(model, body_pose[:3, 3], body_pose[:3, :3])
    else:
        loads = solid_centrifugal_loads(model, body_pose[:3, 3], body_pose[:3, :3])
    out = _projected(model, tied, basis, loads, "centrifugal", problem)
    return out, {"cases": list(CENTRIFUGAL_CASES)}


def acceleration_stiffness(model: FemModel, tied: TiedModel, basis: ModalBasis,
                           body_pose: np.ndarray, problem: ClampedProblem | None = None
                           ) -> np.ndarray:
    """(3, m, m) geometric stiffness per unit uniform acceleration (m/s^2) along each body
    axis: the prestress of the body force rho e_k on the link clamped as its modes are.

    By virtual work it is also minus the Hessian of the link's first moment of mass: the
    mass-weighted second-order displacement is ``int rho u2 dV = -eta^T K_a,k eta / 2``
    along body axis k (a bent link's mass moves towards its reference). Held as
    :meth:`pipeline.invariants.reduced_link.ReducedLink.first_moment_hessian`, it enters
    the link's mass distribution, so that translational accelerations and gravity stiffen
    or soften the modes with the kinetic and potential energy that go with it.
    N m per m/s^2 per modal unit^2.
    """
    loads = acceleration_loads(model, body_pose[:3, :3])
    return _projected(model, tied, basis, loads, "acceleration", problem)


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
    for c, f in enumerate(loads):
        report(f"geometric stiffness, {what} case {c + 1} of {len(loads)}")
        u = expand @ lu.solve(expand.T @ f)
        if model.kind == "beam":
            KG = Phi.T @ (beam_geometric_stiffness(model, beam_axial_forces(model, u)) @ Phi)
        else:
            KG = solid_modal_geometric_stiffness(model, u, Phi)
        out[c] = 0.5 * (KG + KG.T)
    return out

