"""What a link looks like in pictures: points in the body frame, triangles or lines, and
the displacement fields of the kept modes (numpy only; no pyvista here)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from pipeline.post.primitives import cylinder_surface


@dataclass(frozen=True)
class LinkShape:
    """Picture of one link.

    Attributes
    ----------
    link : mechanism link name.
    points : (N, 3) body-frame points, m.
    triangles : (F, 3) point indices, or None.  lines : (L, 2) point indices, or None.
    modes : (k, N, 3) displacement per unit modal coordinate (body frame, m), in the
        order of the link's modal coordinates in the mechanism; None for a rigid link.
    stress : (k, N, 6) Voigt stress per unit modal coordinate (body axes, Pa), or None
        (rigid links, beams).
    """

    link: str
    points: np.ndarray
    triangles: np.ndarray | None = None
    lines: np.ndarray | None = None
    modes: np.ndarray | None = None
    stress: np.ndarray | None = None

    def von_mises(self, eta: np.ndarray) -> np.ndarray | None:
        """(N,) von Mises stress (Pa) at the points for modal coordinates eta (k,), or None
        without stress modes."""
        if self.stress is None or not np.size(eta):
            return None
        from pipeline.fem.stress import von_mises

        return von_mises(np.tensordot(np.asarray(eta, float), self.stress, axes=(0, 0)))

    @cached_property
    def spine(self) -> tuple[np.ndarray, np.ndarray | None] | None:
        """Centre line of a slender surface: ((S, 3) points, (k, S, 3) modal fields or
        None), body frame, m; None for a link that is not slender or is drawn as lines.

        Pictures draw it with a fixed width in pixels, so that a bar 3 mm thick on a
        machine metres wide stays visible. The points are the means of the surface
        points in slices along the principal axis; the modal fields are averaged with the
        same weights, so the line moves with the link.
        """
        W = self.spine_weights
        if W is None:
            return None
        fields = None if self.modes is None else np.einsum("sn,knc->ksc", W, self.modes)
        return W @ self.points, fields

    @cached_property
    def spine_weights(self) -> np.ndarray | None:
        """(S, N) weights of the surface points in each point of :attr:`spine`, or None."""
        return None if self.triangles is None else _slice_means(self.points)

    def spine_von_mises(self, eta: np.ndarray) -> np.ndarray | None:
        """(S,) the largest von Mises stress (Pa) of each slice of the centre line (the
        outer fibre's, which a line drawn on top of the surface would otherwise hide)."""
        v, W = self.von_mises(eta), self.spine_weights
        if v is None or W is None:
            return None
        return np.max(np.where(W > 0, v[None, :], 0.0), axis=1)


def shape_from_reduced(reduced, modes=None, link: str | None = None) -> LinkShape:
    """Surface (solids) or centre line (beams) of a ReducedLink, with the kept modes'
    fields (``modes``: indices in the mechanism's order; default all, [] = rigid)."""
    idx = list(range(reduced.n_modes)) if modes is None else list(modes)
    fields = np.asarray(reduced.mode_shapes)[idx] if idx else None
    surface = np.asarray(reduced.surface)
    if surface.size:
        # corner nodes of the surface only: a linear surface is enough for a picture, and
        # a solid's interior and mid-side nodes would be most of every frame's points
        used, tri = np.unique(surface[:, :3].astype(int), return_inverse=True)
        tri = tri.reshape(-1, 3)
        S = np.asarray(reduced.stress_modes)
        stress = S[idx][:, used].astype(float) if idx and S.size and \
            reduced.kind == "solid" else None
        return LinkShape(link or reduced.name, np.asarray(reduced.nodes, float)[used], tri,
                         None, None if fields is None else fields[:, used], stress)
    lines = np.asarray(reduced.cells)[:, :2].astype(int)
    return LinkShape(link or reduced.name, np.asarray(reduced.nodes, float), None, lines, fields)


def shape_from_surface(link: str, points, triangles) -> LinkShape:
    """Rigid link drawn as a given triangulated surface (body frame, m)."""
    return LinkShape(link, np.asarray(points, float), np.asarray(triangles, int))


def stick_shape(link, radius: float = 0.02) -> LinkShape:
    """Rigid link with no geometry: tubes from the body origin to each frame origin
    (a lone body frame becomes a small sphere-like stub)."""
    origins = [np.asarray(f.pose)[:3, 3] for f in link.frames]
    origins = [o for o in origins if np.linalg.norm(o) > 1e-9]
    pts, tris, n0 = [], [], 0
    ends = [(np.zeros(3), o) for o in origins]
    if len(origins) >= 2:  # also join consecutive frames: links read as plates, not stars
        ends += [(origins[i], origins[i + 1]) for i in range(len(origins) - 1)]
    if not ends:
        ends = [(np.array([-radius, 0.0, 0.0]), np.array([radius, 0.0, 0.0]))]
    for a, b in ends:
        if np.linalg.norm(b - a) < 1e-9:
            continue
        p, t = cylinder_surface(a, b, radius, n=12)
        pts.append(p)
        tris.append(t + n0)
        n0 += len(p)
    return LinkShape(link.name, np.vstack(pts), np.vstack(tris))


def _slice_means(points: np.ndarray, slices: int = 24, slender: float = 0.15):
    """(S, N) weights averaging the points of each slice along the principal axis, or None
    when the second principal extent is more than ``slender`` times the first."""
    X = np.asarray(points, dtype=float)
    c = X.mean(axis=0)
    _, _, vt = np.linalg.svd(X - c, full_matrices=False)
    proj = (X - c) @ vt.T
    extent = np.ptp(proj, axis=0)
    if extent[0] <= 0 or extent[1] > slender * extent[0]:
        return None
    lo, hi = proj[:, 0].min(), proj[:, 0].max()
    # thin end slices, so that the line reaches the link's ends
    edges = np.concatenate([[lo], np.linspace(lo + 0.01 * (hi - lo), hi - 0.01 * (hi - lo),
                                              slices - 1), [hi]])
    which = np.clip(np.searchsorted(edges, proj[:, 0], side="right") - 1, 0, slices - 1)
    W = np.zeros((slices, len(X)))
    W[which, np.arange(len(X))] = 1.0
    W = W[W.sum(axis=1) > 0]
    return W / W.sum(axis=1, keepdims=True)
