"""The mechanism model: links, joints, topology and the coordinate layout.

Generalised coordinates (DESIGN §4): q = [joint variables of every joint, in
the order the joints were listed; modal coordinates of every flexible link,
in link order]. Names are ``"<joint>.<variable>"`` (e.g. ``"crank.theta"``)
and ``"<link>.eta<k>"`` (k from 1).

Building a :class:`Mechanism` also compiles the kinematic tree into *steps*
(:class:`Step`): the pose of a link is its tree parent's pose times a local
matrix M(q) = S_frame(eta) Phi(q) tail, with ``tail`` the constant inverse
shape matrix of the entered frame. Loop closures and markers reuse the same
step form, so one evaluation routine (:mod:`pipeline.kinematics.poses`) gives
poses, derivatives and acceleration terms everywhere.

Examples
--------
>>> from pipeline.kinematics.links import rigid_link
>>> from pipeline.kinematics.joints import Joint
>>> m = build_mechanism([rigid_link("ground"), rigid_link("arm")],
...                     [Joint("pin", "revolute", "ground", "body", "arm", "body", (0.2,))])
>>> m.coordinates, m.q_initial.tolist()
(('pin.theta',), [0.2])
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.kinematics.joints import Joint, MotionSequence
from pipeline.kinematics.links import Frame, Link
from pipeline.kinematics.rotations import inverse
from pipeline.kinematics.topology import Topology, build_topology

__all__ = ["ROW_COMPONENTS", "Mechanism", "Step", "build_mechanism"]

#: Closure rows per loop: position error (global x, y, z, m) then orientation
#: error (global rotation about x, y, z, rad); see :mod:`closure`.
ROW_COMPONENTS = ("position x", "position y", "position z",
                  "rotation x", "rotation y", "rotation z")

_NO_INDEX = np.zeros(0, dtype=int)


@dataclass(frozen=True)
class Step:
    """Local matrix M(q) = S_frame(eta_frm) Phi(q_joint) tail placed on link ``frm``.

    Attributes
    ----------
    frm : index of the link whose pose A_frm the step starts from.
    frame : frame of ``frm`` the step leaves from (its shape matrix S).
    eta_idx : (m,) indices in q of ``frm``'s modal coordinates (empty if rigid).
    motion : joint motion sequence (Phi or Phi^-1), None for no joint.
    q_idx : (k,) indices in q of the joint variables.
    tail : (4, 4) constant right factor, None for the identity.
    local : (m + k,) ``eta_idx`` then ``q_idx``: the coordinates M depends on.
    fast : for a rigid frame with at most one elementary motion, the constant
        matrices of the closed form M(x) = C0 + sin x C1 + (1 - cos x) C2
        (rotation, since G^3 = -G for its generator G) or C0 + x C1
        (translation), with C0 = S0 tail, C1 = S0 G tail, C2 = S0 G^2 tail;
        else None (general product form).
    """

    frm: int
    frame: Frame
    eta_idx: np.ndarray
    motion: MotionSequence | None
    q_idx: np.ndarray
    tail: np.ndarray | None
    local: np.ndarray = field(init=False, repr=False)
    fast: tuple | None = field(init=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "local", np.concatenate([self.eta_idx, self.q_idx]))
        fast = None
        if self.frame.n_modes == 0 and (self.motion is None or self.motion.n == 1):
            tail = np.eye(4) if self.tail is None else self.tail
            C0 = self.frame.pose @ tail
            if self.motion is None:
                fast = ("fixed", C0, None, None, -1)
            else:
                G = self.motion.generators[0]
                fast = (self.motion.kinds[0], C0, self.frame.pose @ G @ tail,
                        self.frame.pose @ G @ G @ tail, int(self.q_idx[0]))
        object.__setattr__(self, "fast", fast)

    @cached_property  # a marker's step is built once per mechanism and evaluated often
    def compiled(self):
        """This step alone as a :class:`pipeline.kinematics.compiled.CompiledSteps`."""
        from pipeline.kinematics.compiled import compile_steps

        return compile_steps([self])


@dataclass(frozen=True)
class StepTable:
    """All steps: the tree steps in placement order, then each loop's two sides.

    Attributes
    ----------
    steps : every step; ``tree_slot[l]`` / ``loop_slot[k]`` index into it.
    """

    steps: tuple[Step, ...]
    tree_slot: tuple[int, ...]
    loop_slot: tuple[tuple[int, int], ...]


def _table(tree, loops, placement) -> StepTable:
    steps, tree_slot = [], [-1] * len(tree)
    for li in placement[1:]:
        tree_slot[li] = len(steps)
        steps.append(tree[li])
    loop_slot = []
    for left, right in loops:
        loop_slot.append((len(steps), len(steps) + 1))
        steps += [left, right]
    return StepTable(tuple(steps), tuple(tree_slot), tuple(loop_slot))


@dataclass(frozen=True)
class Mechanism:
    """Links, joints, topology, coordinate layout and compiled steps (build with
    :func:`build_mechanism`).

    Attributes
    ----------
    coordinates : names of the n coordinates q.
    q_initial : (n,) user's approximate assembly (joint q0, modal 0).
    joint_index : per joint, (k,) indices of its variables in q.
    modal_index : per link, (m,) indices of its modal coordinates in q.
    tree_steps : per link index, the step placing it (None for ground).
    loop_steps : per loop, (parent side, child side) steps of the cut joint.
    length_scale : m, largest frame offset (>= 1e-3); scales position rows.
    placement : link indices, ground first, each after its tree parent.
    table : every step (tree, then loops), indexed by placement and loop.
    """

    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    ground: str
    topology: Topology
    coordinates: tuple[str, ...]
    q_initial: np.ndarray
    joint_index: tuple[np.ndarray, ...]
    modal_index: tuple[np.ndarray, ...]
    tree_steps: tuple[Step | None, ...]
    loop_steps: tuple[tuple[Step, Step], ...]
    length_scale: float
    placement: tuple[int, ...]
    table: StepTable

    @property
    def n(self) -> int:
        """Number of coordinates."""
        return len(self.coordinates)

    @cached_property  # looked up at every evaluation of the equations of motion
    def link_names(self) -> tuple[str, ...]:
        return tuple(l.name for l in self.links)

    @cached_property
    def row_weights(self) -> np.ndarray:
        """(6 k,) closure-row weights, 1/length_scale on positions, 1 on rotations (read-only)."""
        w = np.ones(6 * len(self.topology.loops))
        w.reshape(-1, 6)[:, :3] = 1.0 / self.length_scale
        w.setflags(write=False)
        return w

    @cached_property
    def translations(self) -> np.ndarray:
        """(n,) bool, read-only: the joint coordinates that are lengths (m); the others are
        angles (rad) or modal amplitudes."""
        out = np.zeros(self.n, dtype=bool)
        for j, idx in zip(self.joints, self.joint_index):
            m = j.kind.motion
            for kind, v in zip(m.kinds, m.var):
                out[idx[v]] = kind == "T"
        out.setflags(write=False)
        return out

    @cached_property
    def coordinate_units(self) -> np.ndarray:
        """(n,) natural scale of each coordinate (read-only): 1 for an angle, the length
        scale for a length, and for a modal coordinate the amplitude that moves some frame
        of its link by the length scale. Tolerances and rank decisions in these units treat
        radians, metres and modal amplitudes alike."""
        L = float(self.length_scale)
        unit = np.where(self.translations, L, 1.0)
        for link, idx in zip(self.links, self.modal_index):
            if idx.size:
                amp = np.zeros(idx.size)
                for f in link.frames:
                    amp = np.maximum(amp, np.linalg.norm(f.phi, axis=1)
                                     + L * np.linalg.norm(f.psi, axis=1))
                unit[idx] = L / np.where(amp > 0.0, amp, 1.0)
        unit.setflags(write=False)
        return unit

    @cached_property
    def compiled(self):
        """The flat arrays of :mod:`pipeline.kinematics.compiled` (built on first use)."""
        from pipeline.kinematics.compiled import compile_mechanism  # numba loads only if used
        return compile_mechanism(self)

    @cached_property
    def modal_coordinates(self) -> np.ndarray:
        """(n_eta,) indices of all modal coordinates (read-only)."""
        idx = np.concatenate([_NO_INDEX, *self.modal_index]).astype(int)
        idx.setflags(write=False)
        return idx

    def index(self, name: str) -> int:
        """Index of coordinate ``name`` in q."""
        try:
            return self.coordinates.index(name)
        except ValueError:
            raise ConfigError(f"coordinate '{name}' does not exist; coordinates: "
                              f"{list(self.coordinates)}") from None

    def indices(self, names: Iterable[str]) -> np.ndarray:
        return np.array([self.index(n) for n in names], dtype=int)

    def link_index(self, name: str) -> int:
        try:
            return self.link_names.index(name)
        except ValueError:
            raise ConfigError(f"link '{name}' does not exist; links: "
                              f"{list(self.link_names)}") from None

    def joint_of(self, coordinate: int) -> str | None:
        """Name of the joint owning coordinate index ``coordinate`` (None: modal)."""
        for j, idx in zip(self.joints, self.joint_index):
            if coordinate in idx:
                return j.name
        return None

    def marker(self, link: str, frame: str) -> Step:
        """Step giving the global pose of ``frame`` on ``link``: A_link S_frame(eta)."""
        key = (link, frame)
        step = self._marker_steps.get(key)
        if step is None:  # built once: force elements ask at every evaluation
            li = self.link_index(link)
            step = Step(li, self.links[li].frame(frame), self.modal_index[li], None, _NO_INDEX,
                        None)
            self._marker_steps[key] = step
        return step

    @cached_property
    def _marker_steps(self) -> dict:
        return {}

    def row_names(self) -> tuple[str, ...]:
        """Names of the 6 closure rows of every loop, e.g. "L1 (cut 'D'): position z"."""
        return tuple(f"{lp.name} (cut '{self.joints[lp.cut].name}'): {c}"
                     for lp in self.topology.loops for c in ROW_COMPONENTS)


def _layout(links, joints):
    names, joint_index, k = [], [], 0
    for j in joints:
        n = j.kind.n
        names += [f"{j.name}.{v}" for v in j.kind.variables]
        joint_index.append(np.arange(k, k + n))
        k += n
    modal_index = []
    for l in links:
        names += [f"{l.name}.eta{a + 1}" for a in range(l.n_modes)]
        modal_index.append(np.arange(k, k + l.n_modes))
        k += l.n_modes
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"coordinates: duplicate name(s) {dup}; rename the joints or links")
    q0 = np.concatenate([np.array(j.q0, dtype=float) for j in joints] + [np.zeros(k - sum(
        len(i) for i in joint_index))])
    return tuple(names), q0, tuple(joint_index), tuple(modal_index)


def _compile(links, joints, topo: Topology, joint_index, modal_index):
    index = {l.name: i for i, l in enumerate(links)}
    tree: list[Step | None] = [None] * len(links)
    for e in topo.edges:
        j = joints[e.joint]
        out_f, in_f = (j.parent_frame, j.child_frame) if e.forward else (j.child_frame,
                                                                           j.parent_frame)
        motion = j.kind.motion if e.forward else j.kind.reverse
        tail = inverse(links[e.to].frame(in_f).pose)
        if np.array_equal(tail, np.eye(4)):
            tail = None
        tree[e.to] = Step(e.frm, links[e.frm].frame(out_f), modal_index[e.frm],
                          motion if motion.n else None, joint_index[e.joint], tail)
    loops = []
    for lp in topo.loops:
        j = joints[lp.cut]
        p, c = index[j.parent], index[j.child]
        left = Step(p, links[p].frame(j.parent_frame), modal_index[p],
                    j.kind.motion if j.kind.n else None, joint_index[lp.cut], None)
        right = Step(c, links[c].frame(j.child_frame), modal_index[c], None, _NO_INDEX, None)
        loops.append((left, right))
    return tuple(tree), tuple(loops)


def build_mechanism(links: Sequence[Link], joints: Sequence[Joint],
                    ground: str = "ground") -> Mechanism:
    """Validate the model, build its topology and compile it.

    Parameters
    ----------
    links : links (one of them named ``ground``, rigid).
    joints : joints; their ``q0`` is the approximate assembly.
    ground : name of the fixed link.

    Raises
    ------
    ConfigError, KinematicsError
        See :func:`pipeline.kinematics.topology.build_topology`.
    """
    links, joints = tuple(links), tuple(joints)
    bad = [type(x).__name__ for x in links if not isinstance(x, Link)] + \
          [type(x).__name__ for x in joints if not isinstance(x, Joint)]
    if bad:
        raise ConfigError(f"build_mechanism: expected Link and Joint objects, got {bad}")
    topo = build_topology(links, joints, ground)
    names, q0, jidx, midx = _layout(links, joints)
    tree, loops = _compile(links, joints, topo, jidx, midx)
    offsets = [np.linalg.norm(f.pose[:3, 3]) for l in links for f in l.frames]
    scale = max([1e-3] + offsets)
    placement = tuple([links.index(next(l for l in links if l.name == ground))]
                      + [e.to for e in topo.edges])
    return Mechanism(links, joints, ground, topo, names, q0, jidx, midx, tree, loops, scale,
                     placement, _table(tree, loops, placement))
