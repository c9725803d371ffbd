"""Does a reduction basis carry the link's load paths? Static coverage of its frames.

The reduction stores the full FE model's compliance C between the link's frames
(:func:`pipeline.modes.compliance.interface_statics`, in the artifact's meta). Its
attachment modes (the static deflections under unit loads at the frames) are a Ritz basis
with exactly the full model's static behaviour at the frames; the kept modes are another.
For a load at a frame, the compliance each reproduces -- the largest (w.u)^2 / strain
energy over its motions u, under whatever the machine holds -- is compared: the kept modes'
share (Rayleigh-Ritz keeps it <= 1) is how much of the link's static flexibility there the
model can show.

Held at its reference only, a link clamped at one small bore reproduces its far frames'
compliance well. In a machine that also holds it elsewhere (a boom on its cylinder) the
same modes can be nearly useless: they are rotations about the bore, which the second
support forbids, and the bending between the supports is not in the basis (a knuckle boom
came out 7x too stiff). :func:`constrained_coverage` measures that case with the
conditions the assembled machine imposes (``pipeline.workflow.model_checks``).

Nothing here reads the FE model: the checks run on the artifact's arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from pipeline.invariants.planar_modes import link_mode_planes, without_plane_round_off

#: directions of a frame's six motions, body axes
DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")

#: a share of the static compliance below this is reported (10 % of the flexibility missing)
MIN_COVERAGE = 0.9

#: directions softer than this share of the link's softest frame translation count (an
#: axial direction of a slender link, 1e-4 to 1e-3 of its bending compliance, or a pin the
#: machine holds fast, is not worth a warning)
RELEVANT_SHARE = 1e-2

#: a held row whose motion on the kept modes is below this share of their largest frame
#: motion holds nothing (round-off of an asymmetric mesh, not a load path)
HOLD_RTOL = 1e-6


@dataclass(frozen=True)
class Coverage:
    """Static compliance of one frame direction, full FE model vs kept modes.

    Attributes
    ----------
    frame, direction : the frame's name and one of :data:`DIRECTIONS` (body axes).
    full, kept : compliance of the full FE model and of the kept modes, m/N (rotations
        rad/(N m)).
    relevant : the direction is soft enough to matter (see :data:`RELEVANT_SHARE`).
    """

    frame: str
    direction: str
    full: float
    kept: float
    relevant: bool

    @property
    def ratio(self) -> float:
        """kept / full (1 where the full model has no compliance there)."""
        return 1.0 if self.full <= 0 else self.kept / self.full


def stored_compliance(link) -> tuple[tuple[str, ...], np.ndarray] | None:
    """(frame names, (6F, 6F) compliance) the reduction stored, or None for an artifact
    made before it was measured."""
    entry = link.meta.get("interface_compliance")
    if not entry:
        return None
    n = 6 * len(entry["frames"])
    return tuple(entry["frames"]), np.asarray(entry["matrix"], dtype=float).reshape(n, n)


def frame_motions(link, modes=None) -> tuple[tuple[str, ...], np.ndarray, np.ndarray,
                                               np.ndarray] | None:
    """(names, G, K, C) of the frames with stored compliance: G (6F, m) each frame's
    [translation; rotation] per kept mode (body axes; an in-plane mode without its mesh's
    round-off across the plane, :mod:`pipeline.invariants.planar_modes`), K (m, m) the
    kept modal stiffness, C (6F, 6F) the full model's compliance; None without stored
    compliance."""
    stored = stored_compliance(link)
    if stored is None:
        return None
    names, C = stored
    idx = list(range(link.n_modes)) if modes is None else list(modes)
    planes = link_mode_planes(link, idx)  # as the machine sees them (frame_views)
    G = np.vstack([np.vstack([m.T for m in without_plane_round_off(
        link.frame(n).phi[idx], link.frame(n).psi[idx], planes)])
        for n in names]) if names else np.zeros((0, len(idx)))
    K = np.asarray(link.modal_stiffness, dtype=float)[np.ix_(idx, idx)]
    return names, G, K, C


def static_coverage(link, modes=None, directions=DIRECTIONS[:3]) -> list[Coverage]:
    """Coverage of each stored frame's ``directions`` (body axes) by the kept ``modes``
    (default all), the link held at its reference only (a cantilever from its reference:
    right for an open chain; a machine holds it elsewhere too, see
    :func:`constrained_coverage`). [] without stored compliance."""
    fm = frame_motions(link, modes)
    if fm is None:
        return []
    names, G, K, C = fm
    rows = [(n, d, np.eye(len(C))[6 * i + DIRECTIONS.index(d)])
            for i, n in enumerate(names) for d in directions]
    return constrained_coverage(G, K, C, rows, np.zeros((0, len(C))))


def constrained_coverage(G: np.ndarray, K: np.ndarray, C: np.ndarray, rows,
                         held: np.ndarray, scale: float | None = None) -> list[Coverage]:
    """Coverage of loaded directions under linear conditions on the frames' motions.

    Parameters
    ----------
    G, K, C : as :func:`frame_motions` returns them.
    rows : (frame, direction, w) with w (6F,): the loaded direction's displacement is
        w . u for frame motions u (a frame's own row, or, in a machine, its ground
        displacement including the rigid motion the loops give the link).
    held : (k, 6F) combinations of frame motions the machine holds at zero.
    scale : the compliance that counts as large, m/N (a machine: its softest loaded
        frame, over all its flexible links); default the largest translational full
        compliance among ``rows``.

    Returns
    -------
    one Coverage per row; ``relevant`` where its full compliance is at least
    :data:`RELEVANT_SHARE` of ``scale``: a frame the machine holds fast (a two-force
    link's far pin) has little worth carrying.
    """
    Ga, Ka = attachment_basis(C)
    covers = [Coverage(frame, d, ritz_compliance(Ga, Ka, w, held),
                       ritz_compliance(G, K, w, held), relevant=False)
              for frame, d, w in rows]
    return with_relevance(covers, softest(covers) if scale is None else scale)


def softest(covers: list[Coverage]) -> float:
    """The largest translational full compliance among ``covers``, m/N (0 if none)."""
    return max((c.full for c in covers if not c.direction.startswith("r")), default=0.0)


def with_relevance(covers: list[Coverage], scale: float) -> list[Coverage]:
    """``covers`` marked relevant where the full compliance is at least
    :data:`RELEVANT_SHARE` of ``scale`` (rotations: wherever it is not zero)."""
    return [replace(c, relevant=c.full > 0 and (c.direction.startswith("r") or
                                                c.full >= RELEVANT_SHARE * scale))
            for c in covers]


def basis_remedy(constraint_modes: bool, modes_key: str = "modes.count") -> str:
    """What to do about a basis that misses compliance: more modes, or (a basis without
    static constraint modes) Craig-Bampton modes; ``modes_key`` names where the count is
    set."""
    if constraint_modes:
        return f"keep more of its modes ({modes_key})"
    return (f"reduce it with Craig-Bampton modes (modes: {{craig_bampton: true}} in its link "
            f"spec), whose static modes carry the interfaces' loads, or keep more modes "
            f"({modes_key})")


def attachment_basis(C: np.ndarray, rtol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """(G, K) of the full model's static response at the frames as a Ritz basis.

    The attachment modes K^-1 G^T (the static deflections under the frames' unit loads)
    move the frames by C and store C in strain energy; in C's eigenvectors V (eigenvalues
    lam above ``rtol`` of the largest) that is G = V sqrt(lam), K = I: the same static
    behaviour at the frames as the whole FE model's.
    """
    lam, V = np.linalg.eigh(0.5 * (C + C.T))
    keep = lam > rtol * max(float(lam.max(initial=0.0)), 1e-300)
    return V[:, keep] * np.sqrt(lam[keep]), np.eye(int(keep.sum()))


def ritz_compliance(G: np.ndarray, K: np.ndarray, w: np.ndarray, held: np.ndarray) -> float:
    """Compliance (w.u)^2 / energy maximised over the frame motions u = G a of a Ritz model
    (coordinates a, stiffness K (m, m), G (6F, m)) with held @ u = 0.

    (w G Z) (Z^T K Z)^-1 (w G Z)^T, Z the combinations the held rows leave free
    (:func:`free_combinations`).
    """
    return _quadratic(w @ G, free_combinations(G, held), K)


def free_combinations(G: np.ndarray, held: np.ndarray) -> np.ndarray:
    """(m, r) the combinations of a Ritz model's m coordinates (frame motions G (6F, m))
    that the held rows (k, 6F) leave free. A held row that moves a coordinate by less than
    :data:`HOLD_RTOL` of that coordinate's own largest frame translation holds nothing
    there (round-off of a mesh that is not quite symmetric is no load path, and must not
    lock a mode)."""
    m = G.shape[1]
    if not held.size or m == 0:
        return np.eye(m)
    translations = [k for k in range(G.shape[0]) if k % 6 < 3]
    size = np.abs(G[translations]).max(axis=0, initial=0.0)
    # a mode that moves no frame (zero at every frame) is measured against the others
    size = np.maximum(size, HOLD_RTOL * max(float(size.max(initial=0.0)), 1e-300))
    # each coordinate measured against its own largest frame motion (the held rows are per
    # unit frame motion: O(1) where they act, round-off where they do not)
    _, s, Vt = np.linalg.svd(held @ G / size, full_matrices=True)
    rank = int(np.sum(s > HOLD_RTOL))
    return (Vt[rank:] / size).T


def _quadratic(load: np.ndarray, Z: np.ndarray, K: np.ndarray) -> float:
    """The compliance load (Z^T K Z)^-1 load of a Ritz model restricted to Z (m, r); 0 with
    nothing free."""
    if Z.shape[1] == 0:
        return 0.0
    g = load @ Z
    return float(g @ np.linalg.solve(Z.T @ K @ Z, g))


#: the "frame" of the coverage rows that measure a link's own weight and inertia
BODY_LOAD = "its own weight and inertia"


def body_load_coverage(link, modes=None, held: np.ndarray | None = None,
                       rigid: np.ndarray | None = None) -> list[Coverage]:
    """Coverage of a link's own weight and inertia (a uniform acceleration along each body
    axis) by its kept ``modes``: the work of the load on the kept-mode deflection against
    the full FE model's (its response stored by the reduction), under ``held`` (k, 6F)
    combinations of the frames' motions (default: the link held at its reference only).
    [] without the stored response (an artifact made before it was measured).

    ``rigid`` (6F, 3): the load's work over the rigid motion the machine gives the link per
    unit motion of its frames (:func:`pipeline.workflow.model_checks.machine_conditions`),
    a load r at the frames added to the distributed one: full model f + G^T r, of work
    c + 2 r.g + r.C r and frame deflection u = g + C r, under the held rows
    c_tot - (H u)^T (H C H^T)^+ (H u) (the supports' reactions taking their share); kept
    modes L'^T Z (Z^T K Z)^-1 Z^T L' with L' = L + G^T r, L = int rho phi dV the modal load
    of a unit acceleration (C'_a's last row).
    """
    fm = frame_motions(link, modes)
    entry = (link.meta.get("interface_compliance") or {}).get("body_load")
    if fm is None or not entry:
        return []
    _, G, K, C = fm
    g, c = np.asarray(entry["frames"], dtype=float).reshape(-1, 3), np.asarray(entry["work"])
    idx = list(range(link.n_modes)) if modes is None else list(modes)
    L = np.asarray(link.Cp, dtype=float)[idx, 3, :3] if idx else np.zeros((0, 3))
    H = np.zeros((0, len(C))) if held is None else np.asarray(held, dtype=float)
    r = np.zeros((len(C), 3)) if rigid is None else np.asarray(rigid, dtype=float)
    Z = free_combinations(G, H)
    Hk = _held_directions(H)
    rows = []
    for d in range(3):
        u = g[:, d] + C @ r[:, d]
        full = float(c[d, d] + 2.0 * r[:, d] @ g[:, d] + r[:, d] @ C @ r[:, d])
        if Hk.size:
            hu = Hk @ u
            full -= float(hu @ np.linalg.solve(Hk @ C @ Hk.T, hu))
        kept = _quadratic(L[:, d] + G.T @ r[:, d], Z, K)
        rows.append(Coverage(BODY_LOAD, DIRECTIONS[d], max(full, 0.0), kept, False))
    return rows


def _held_directions(H: np.ndarray) -> np.ndarray:
    """(k, 6F) orthonormal rows spanning the held rows H of the frames' motions: per unit
    frame motion they are O(1) where they hold and round-off (1e-17) where they do not, so
    singular values above :data:`HOLD_RTOL` count."""
    if not H.size:
        return H
    _, s, Vt = np.linalg.svd(H, full_matrices=False)
    return Vt[:int(np.sum(s > HOLD_RTOL))]


def body_relevance(rows: list[Coverage], mass: float, scale: float) -> list[Coverage]:
    """Body-load rows (:func:`body_load_coverage`) marked relevant where the work over the
    squared mass, c / m^2 (m/N: the compliance of the link's weight as if at one point), is
    at least :data:`RELEVANT_SHARE` of ``scale`` (m/N, the frames' softest): a stiff link's
    own weight is then no finding."""
    m2 = max(float(mass) ** 2, 1e-300)
    return [replace(c, relevant=c.full > 0 and c.full / m2 >= RELEVANT_SHARE * scale)
            for c in rows]


def coverage_warnings(link_name: str, rows: list[Coverage], remedy: str,
                      condition: str = "held at its reference") -> list[str]:
    """One line (or none) for a link whose kept modes under-represent relevant directions
    (below :data:`MIN_COVERAGE`), naming each frame's directions and shares, the
    ``condition`` and the ``remedy``."""
    by_frame: dict[str, list[Coverage]] = {}
    for c in rows:
        if c.relevant and c.ratio < MIN_COVERAGE:
            by_frame.setdefault(c.frame, []).append(c)
    if not by_frame:
        return []
    what = "; ".join(", ".join(f"{c.direction} {100 * c.ratio:.0f} %" for c in cs)
                     + (f" under {frame}" if frame == BODY_LOAD else f" at {frame!r}")
                     for frame, cs in by_frame.items())
    return [(f"link {link_name!r}, {condition}: its kept modes carry only {what} of the "
             f"full FE model's static compliance (body axes), so it comes out too stiff; "
             f"{remedy}")]


def coverage_report(link, modes=None, directions=DIRECTIONS[:3]) -> dict:
    """The static coverage of a link's frames by its (kept) modes, the link held at its
    reference only (:func:`static_coverage`).

    Returns
    -------
    {"rows": [{frame, direction, share, relevant}] (share of the full FE model's
    compliance, 0..1), "warnings": [...]} (empty rows without stored compliance).
    """
    frames = static_coverage(link, modes, directions)
    rows = frames + body_relevance(body_load_coverage(link, modes), link.mass, softest(frames))
    return {"rows": [{"frame": c.frame, "direction": c.direction, "share": c.ratio,
                      "relevant": c.relevant} for c in rows],
            "warnings": coverage_warnings(link.name, rows,
                                          basis_remedy("constraint" in link.mode_kinds))}


#: a mode whose estimated discretisation error exceeds this share is reported
MESH_RTOL = 1e-2


def frequency_convergence(fine_hz, coarse_hz, rate: int) -> list[dict]:
    """Each mode's frequency on a mesh and on one twice as coarse, and its estimated
    discretisation error, by Richardson extrapolation: an error that falls as h^rate (4
    for P2 tetrahedra and Hermite beams, whose eigenvalues converge as h^4; 2 for P1) is
    about (f_coarse - f) / (2^rate - 1) on the finer mesh.

    Returns
    -------
    [{"mode", "hz", "coarse_hz", "change", "error"}] (relative to ``hz``), modes matched by
    order up to the shorter list (a pair of modes that swap places between the meshes
    shows as two large changes).
    """
    fine, coarse = np.asarray(fine_hz, float), np.asarray(coarse_hz, float)
    out = []
    for k in range(min(fine.size, coarse.size)):
        change = (coarse[k] - fine[k]) / fine[k] if fine[k] > 0 else float("nan")
        out.append({"mode": k, "hz": float(fine[k]), "coarse_hz": float(coarse[k]),
                    "change": float(change), "error": float(change / (2 ** rate - 1))})
    return out


def mesh_warnings(link_name: str, rows: list[dict], key: str) -> list[str]:
    """One line (or none) naming the modes whose estimated error exceeds
    :data:`MESH_RTOL`, with the remedy (``key``: the spec's mesh size field)."""
    bad = [r for r in rows if abs(r["error"]) > MESH_RTOL]
    if not bad:
        return []
    what = ", ".join(f"mode {r['mode']} ({r['hz']:.4g} Hz) {100 * r['error']:+.2g} %"
                     for r in bad)
    return [(f"link {link_name!r}: the mesh is not converged for {what} (estimated "
             f"discretisation error, from a mesh twice as coarse); refine {key}")]
