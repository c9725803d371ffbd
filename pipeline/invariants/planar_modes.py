"""Modes that move in one plane of their link, up to an asymmetric mesh's round-off.

A link symmetric about a plane of its body axes (a boom's side plane, a plate's
mid-plane) has modes that move either in that plane or across it. Its FE mesh is
rarely symmetric too (unstructured tetrahedra, a curved bore's facets), so an in-plane
mode comes out with a little out-of-plane motion at the frames: 1e-6 to 1e-4 of its
in-plane motion on the meshes tried here. In a machine whose loops are planar, that
round-off is all a joint's out-of-plane row sees of the mode, and it is enough to make
the row independent: the loops then hold the mode at zero (a knuckle boom's only kept
mode came out locked, its sag exactly zero).

:func:`mode_planes` finds, per mode, the body-axis planes its frames move in to within
:data:`PLANE_RTOL` of its largest frame motion; :func:`without_plane_round_off` sets the
frames' motion across those planes to zero. The multibody side applies it to every
flexible link without an explicit ``plane`` (:func:`pipeline.dynamics.bodies.frame_views`)
and the model checks to the same modes, so both see the same loops. What is dropped is
at most PLANE_RTOL of the mode's frame motion; a mode that truly moves across the plane
(coupled by an offset lug or a skew section) keeps all of it.

Examples
--------
>>> import numpy as np
>>> phi = np.array([[[0.0, 1.0, 2e-6]]])  # one frame, one mode: y with a trace of z
>>> psi = np.array([[[0.0, 0.0, 0.5]]])
>>> mode_planes(phi, psi, length=1.0)
(('xy',),)
>>> without_plane_round_off(phi[0], psi[0], mode_planes(phi, psi, 1.0))[0]
array([[0., 1., 0.]])
"""

from __future__ import annotations

import numpy as np

__all__ = ["PLANES", "PLANE_RTOL", "link_mode_planes", "mode_planes", "without_plane_round_off"]

#: out-of-plane frame motion below this share of a mode's largest in-plane frame motion is
#: an asymmetric mesh's round-off (1e-6..1e-4 measured), not a motion across the plane
PLANE_RTOL = 1e-3

#: motion across each plane of the body axes: (translation axis, rotation axes)
PLANES = {"xy": (2, (0, 1)), "yz": (0, (1, 2)), "xz": (1, (0, 2))}


def mode_planes(phi: np.ndarray, psi: np.ndarray, length: float) -> tuple[tuple[str, ...], ...]:
    """The body-axis planes each mode moves in.

    Parameters
    ----------
    phi, psi : (F, m, 3) translation (m) and small rotation (rad) of F frames per unit
        modal coordinate, body axes.
    length : the link's size, m: rotations count as the translation they give over it.

    Returns
    -------
    per mode, the planes ("xy", "xz", "yz") across which its frames move by at most
    :data:`PLANE_RTOL` of their largest motion in the plane (an axial mode is in two);
    () for a mode that moves no frame or moves across every plane.
    """
    phi, psi = np.asarray(phi, dtype=float), np.asarray(psi, dtype=float)
    if phi.size == 0:
        return ((),) * (phi.shape[1] if phi.ndim == 3 else 0)
    out = []
    for a in range(phi.shape[1]):
        planes = []
        for plane, (t, (r1, r2)) in PLANES.items():
            t_in = [k for k in range(3) if k != t]
            r_in = next(k for k in range(3) if k not in (r1, r2))
            across = max(np.abs(phi[:, a, t]).max(),
                         length * np.abs(psi[:, a, [r1, r2]]).max())
            within = max(np.abs(phi[:, a, t_in]).max(), length * np.abs(psi[:, a, r_in]).max())
            if within > 0.0 and across <= PLANE_RTOL * within:
                planes.append(plane)
        out.append(tuple(planes))
    return tuple(out)


def without_plane_round_off(phi: np.ndarray, psi: np.ndarray, planes
                            ) -> tuple[np.ndarray, np.ndarray]:
    """(phi, psi) (m, 3) of one frame with each mode's motion across its ``planes``
    (:func:`mode_planes`, one entry per mode) set to zero."""
    phi, psi = np.array(phi, dtype=float), np.array(psi, dtype=float)
    for a, ps in enumerate(planes):
        for plane in ps:
            t, r = PLANES[plane]
            phi[a, t] = 0.0
            psi[a, list(r)] = 0.0
    return phi, psi


def link_mode_planes(reduced, idx) -> tuple[tuple[str, ...], ...]:
    """:func:`mode_planes` of a ReducedLink's modes ``idx`` over all its stored frames, its
    size the extent of its mesh."""
    idx = list(idx)
    if not idx or not reduced.frames:
        return ((),) * len(idx)
    phi = np.array([np.asarray(f.phi)[idx] for f in reduced.frames])
    psi = np.array([np.asarray(f.psi)[idx] for f in reduced.frames])
    nodes = np.asarray(reduced.nodes, dtype=float)
    length = float(np.linalg.norm(np.ptp(nodes, axis=0))) if nodes.size else 1.0
    return mode_planes(phi, psi, length)
