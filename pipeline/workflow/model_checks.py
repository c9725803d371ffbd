"""Checks of the model a workflow builds, before anything runs: can it represent what the
machine asks of it? Each finding is one line naming the link, the figure and the remedy;
the analyses that depend on it are then ``suspect``, never ``ok``.

Reduction basis (:mod:`pipeline.invariants.adequacy`): for each flexible link, the static
compliance its kept modes carry where the machine loads it, with the machine's own
supports. The link's frames are given one coordinate per motion ("unit modes"), and the
machine's closure Jacobian at its initial configuration, drivers held, tells

* which combinations of the frames' motions the loops hold (what the other joints cannot
  take up: the cylinder that holds a boom's lug), and
* how far each frame moves over ground when the frames move (a boom turning about its foot
  as its lug moves along the cylinder),

and the kept modes are compared with the full FE model's static response
(its attachment modes) under those same conditions.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pipeline.invariants.adequacy import (
    DIRECTIONS,
    basis_remedy,
    body_load_coverage,
    body_relevance,
    constrained_coverage,
    coverage_warnings,
    frame_motions,
    softest,
    with_relevance,
)
from pipeline.invariants.planar_modes import PLANES
from pipeline.invariants.reduced_link import FrameModes
from pipeline.workflow.schema import MARKER_FIELDS

#: the body-axis directions that matter in each kept plane (all three without one)
_PLANE_DIRECTIONS = {None: DIRECTIONS[:3], **{
    plane: tuple(d for k, d in enumerate(DIRECTIONS[:3]) if k != across)
    for plane, (across, _) in PLANES.items()}}


def basis_warnings(wf, machine) -> tuple[str, ...]:
    """One line per flexible link whose kept modes miss a share of the static compliance
    where the machine loads it (joints and force elements) or of its own weight and
    inertia (:func:`pipeline.invariants.adequacy.body_load_coverage`), on the machine's
    supports.

    A direction counts when its compliance is at least
    :data:`pipeline.invariants.adequacy.RELEVANT_SHARE` of the softest the machine is: the
    largest over its flexible links of their loaded frames' compliance in the machine and
    of their frames' compliance held at the reference only (a connecting rod loaded at its
    pins only along its axis still bends under its own inertia; its own weight counts as
    the work over its squared mass, :func:`pipeline.invariants.adequacy.body_relevance`).
    A stiff link's far pin that its loop holds fast is then no finding. A flexible link
    kept rigid (no modes: a
    modelling choice, the rigid case of a mode study) is not checked, but its full FE
    compliance still sets how soft the machine is. A link the machine moves and loads in
    one plane of its body axes (:func:`machine_plane`) is checked in that plane, as one
    with ``plane`` set.
    """
    checked, scale = [], 0.0
    for name, part in machine.parts.items():
        entry = wf.spec.links[name]
        if entry.type != "flexible" or frame_motions(part.reduced) is None:
            continue
        plane = getattr(entry, "plane", None) or machine_plane(machine, name)
        rows, held, _, rigid = machine_conditions(wf, machine, name, plane)
        _, G, K, C = frame_motions(part.reduced, part.modes)
        cover = constrained_coverage(G, K, C, rows, held)
        body = [c for c in body_load_coverage(part.reduced, part.modes, held, rigid)
                if c.direction in _PLANE_DIRECTIONS[plane]]
        weight = max((c.full for c in body), default=0.0) / max(part.reduced.mass, 1e-300) ** 2
        # held at its reference only, a frame's full compliance is C's diagonal entry
        asked = [DIRECTIONS.index(d) for d in _PLANE_DIRECTIONS[plane]]
        alone = max((C[k, k] for k in range(len(C)) if k % 6 in asked), default=0.0)
        scale = max(scale, alone, softest(cover), weight)
        if part.modes:
            checked.append((name, part, cover, body))
    out: list[str] = []
    for name, part, cover, body in checked:
        constraint = any(part.reduced.mode_kinds[a] == "constraint" for a in part.modes)
        out += coverage_warnings(name, with_relevance(cover, scale)
                                 + body_relevance(body, part.reduced.mass, scale),
                                 basis_remedy(constraint, f"links.{name}.modes"),
                                 "on the machine's supports")
    return tuple(out)


def held_mode_notes(wf, machine) -> tuple[str, ...]:
    """One line per modal motion the loops hold at zero at the initial configuration
    (:func:`pipeline.kinematics.partition.held_modes`): which link, which of its modes,
    through which closure row, and what to do. Not a finding by itself (a planar loop
    holding a link's out-of-plane modes is expected); where it costs the machine
    flexibility the basis check says so."""
    from pipeline.kinematics.failures import SingularConfigurationError
    from pipeline.kinematics.partition import held_modes

    try:
        held = held_modes(machine.mechanism, machine.q0, list(machine.system.drivers))
    except SingularConfigurationError:  # a singular start: the analyses say so
        return ()
    out = []
    for h in held:
        part = machine.parts[h.link]
        mech = machine.mechanism
        own = [mech.coordinates[i] for i in mech.modal_index[mech.link_index(h.link)]]
        modes = ", ".join(f"{c} ({part.reduced.frequencies_hz[part.modes[own.index(c)]]:.4g} Hz)"
                          for c in h.coordinates)
        out.append(f"link {h.link!r}: the loops hold its mode motion {modes} at zero through "
                   f"{h.row}: no joint can follow that motion there, so it adds no "
                   f"flexibility. If the link should deform there, reduce it with "
                   f"Craig-Bampton modes (modes: {{craig_bampton: true}} in its link spec); "
                   f"if not, keep only modes the loops let move (links.{h.link}.plane or "
                   f"links.{h.link}.modes)")
    return tuple(out)


def machine_plane(machine, name: str, rtol: float = 1e-9) -> str | None:
    """The plane of link ``name``'s body axes that the machine moves and loads it in, or
    None: every joint coordinate turns the link about that plane's normal and moves it
    along the plane, and gravity and the point forces and torques lie in it (a planar
    machine built in 3-D). Such a link needs no flexibility across the plane."""
    from pipeline.kinematics import evaluate_tree
    from pipeline.kinematics.rotations import vee

    mech = machine.mechanism
    li = mech.link_index(name)
    tree = evaluate_tree(mech, machine.q0)
    joints = np.setdiff1d(np.arange(mech.n), mech.modal_coordinates).astype(int)
    R = tree.A[li][:3, :3]
    turns = [vee(tree.dA[li][k][:3, :3] @ R.T) for k in joints]
    moves = [tree.dA[li][k][:3, 3] for k in joints]
    if not any(np.abs(np.concatenate([*turns, *moves, np.zeros(1)])) > 0):
        return None  # the machine does not move it: no plane to read
    g = np.asarray(machine.system.gravity, dtype=float)
    L = float(mech.length_scale)
    loads = [np.asarray(f.force, dtype=float) for f in machine.system.forces
             if getattr(f, "force", None) is not None]
    torques = [np.asarray(f.torque, dtype=float) for f in machine.system.forces
               if getattr(f, "torque", None) is not None]
    if any(getattr(f, "follower", False) for f in machine.system.forces):
        return None  # turns with its marker: no fixed plane to read
    for plane, (axis, _) in PLANES.items():
        n = R[:, axis]
        across = [np.linalg.norm(np.cross(n, w)) * L for w in turns + torques]
        across += [abs(n @ v) for v in moves] + [abs(n @ f) / max(np.linalg.norm(f), 1e-300)
                                                for f in [g, *loads] if np.any(f)]
        scale = max([np.linalg.norm(w) * L for w in turns] + [np.linalg.norm(v) for v in moves])
        if max(across, default=0.0) <= rtol * max(scale, 1.0):
            return plane
    return None


def machine_conditions(wf, machine, name: str, plane: str | None):
    """(rows, held, frame names, rigid work) of link ``name`` in the machine at its initial
    configuration, drivers held and the other links rigid.

    rows : (frame, direction, w) for every frame a joint or a force element loads
        (:func:`loaded_frames`; a workflow frame moves with the stored frame it is fixed
        on); w (6F,) is its ground displacement along the body axis ``direction`` per unit
        motion of the link's frames, the rigid motion the loops give the link included.
    held : (k, 6F) combinations of frame motions the loops hold at zero.
    rigid work : (6F, 3) the work of a unit acceleration along each body axis on the link
        (its own weight and inertia) over the rigid motion the loops give it per unit
        motion of its frames (a boom that turns about its foot as its lug moves).
    """
    from pipeline.dynamics.bodies import frame_views
    from pipeline.kinematics import build_mechanism, evaluate_tree
    from pipeline.kinematics.closure import closure_jacobian
    from pipeline.kinematics.links import link_from_frames

    mech = machine.mechanism
    red = machine.parts[name].reduced
    names = frame_motions(red)[0]
    F = len(names)
    # one coordinate per motion of each stored frame (the reference does not move)
    unit = []
    for f in red.frames:
        phi, psi = np.zeros((6 * F, 3)), np.zeros((6 * F, 3))
        if f.name in names:
            i = names.index(f.name)
            phi[6 * i:6 * i + 3] = np.eye(3)
            psi[6 * i + 3:6 * i + 6] = np.eye(3)
        unit.append(FrameModes(f.name, f.pose, phi, psi, f.kind))
    probe = replace(red, frames=tuple(unit))
    where = wf.where("links", name, "frames")
    li = mech.link_index(name)
    # the workflow's own frames on the link, fixed on a stored one: their local pose
    posed = {f.name: f.pose for f in mech.links[li].frames}
    extra = {k: (v.on, np.linalg.solve(red.frame(v.on).pose, posed[k]))
             for k, v in wf.spec.links[name].frames.items()}
    views = frame_views(probe, range(6 * F), plane, False, extra, where)
    links = list(mech.links)
    links[li] = link_from_frames(name, views)
    probe_mech = build_mechanism(links, mech.joints)
    q = np.zeros(probe_mech.n)
    for k, c in enumerate(probe_mech.coordinates):
        if c in mech.coordinates:
            q[k] = machine.q0[mech.coordinates.index(c)]
    own = np.asarray(probe_mech.modal_index[li], dtype=int)
    driven = set(probe_mech.indices(list(machine.system.drivers))) if \
        machine.system.drivers else set()
    others = [k for k in range(probe_mech.n) if k not in set(own) | driven
              and k not in set(probe_mech.modal_coordinates)]
    J = closure_jacobian(probe_mech, q)[1] if probe_mech.table.loop_slot else \
        np.zeros((0, probe_mech.n))
    Jo, B = J[:, others], J[:, own]
    take_up = np.linalg.pinv(Jo, rcond=1e-10) @ B if Jo.size else np.zeros((len(others), 6 * F))
    held = B - Jo @ take_up if Jo.size else B
    tree = evaluate_tree(probe_mech, q)
    A, dA = tree.A[li], tree.dA[li]
    rows = []
    by_name = {v.name: v for v in views}
    for n in sorted(loaded_frames(wf, mech, name), key=list(by_name).index):
        view = by_name[n]  # a stored frame, or one the workflow fixes on a stored frame
        p = np.append(view.pose[:3, 3], 1.0)
        W = A[:3, :3] @ view.phi.T  # its own motion per unit frame motion, ground axes
        W -= (dA[others] @ p)[:, :3].T @ take_up  # the rigid motion the loops give it
        Wb = A[:3, :3].T @ W  # read along the body axes
        rows += [(n, d, Wb[DIRECTIONS.index(d)]) for d in _PLANE_DIRECTIONS[plane]]
    # int rho [r; 1] dV of the link in its body frame: [m c; m]
    C4 = np.asarray(red.C, dtype=float)[:, 3]
    rigid = -np.einsum("kij,j,kc->ci", dA[others][:, :3, :], C4, take_up) @ A[:3, :3] \
        if Jo.size else np.zeros((6 * F, 3))
    return rows, held, names, rigid


def loaded_frames(wf, mech, name: str) -> set[str]:
    """Frames of link ``name`` that a joint or a force element acts at."""
    out = {fr for j in mech.joints for ln, fr in ((j.parent, j.parent_frame),
                                                  (j.child, j.child_frame)) if ln == name}
    for f in wf.spec.forces:
        for key in MARKER_FIELDS:
            at = (f.model_extra or {}).get(key)
            if isinstance(at, str) and at.startswith(f"{name}."):
                out.add(at.split(".", 1)[1])
    return out
