"""Topology: spanning tree from ground, cut joints and independent loops.

Links are nodes and joints edges of a graph. A breadth-first search from the
ground link (joints taken in the order the user listed them) builds the
spanning tree; every joint left over is a *cut joint* and closes one
independent loop (loops = joints - links + 1 for a connected graph).

The tree must enter each link through a frame that does not move with the
link's modal coordinates (its body frame for a flexible link): then every
link pose is A_child = A_parent S_parent(eta) Phi(q) S_child^-1 with a
*constant* S_child^-1, and all poses stay linear in each link's eta. A
flexible link whose only joints sit at deforming frames is reported.

Examples
--------
>>> from pipeline.kinematics.links import rigid_link
>>> from pipeline.kinematics.joints import Joint
>>> topo = build_topology((rigid_link("ground"), rigid_link("arm")),
...                       (Joint("pin", "revolute", "ground", "body", "arm", "body"),), "ground")
>>> topo.order, topo.cut_joints
(('ground', 'arm'), ())
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from pipeline.core.errors import ConfigError, KinematicsError
from pipeline.kinematics.joints import Joint
from pipeline.kinematics.links import Link

__all__ = ["Loop", "Topology", "TreeEdge", "build_topology"]


@dataclass(frozen=True)
class TreeEdge:
    """Tree joint ``joint`` (index) placing link ``to`` from link ``frm``.

    ``forward`` is True when ``frm`` is the joint's parent (the tree uses
    Phi(q)), False when the tree crosses the joint from child to parent
    (it uses Phi(q)^-1).
    """

    joint: int
    frm: int
    to: int
    forward: bool


@dataclass(frozen=True)
class Loop:
    """Independent loop closed by cut joint ``cut`` (index).

    ``joints`` lists every joint index in the loop (tree joints and the cut
    joint); ``links`` the link indices around it.
    """

    name: str
    cut: int
    joints: tuple[int, ...]
    links: tuple[int, ...]


@dataclass(frozen=True)
class Topology:
    """Spanning tree (``edges`` in placement order), ``order`` of link names
    (ground first, each link after its tree parent), cut joints and loops."""

    order: tuple[str, ...]
    edges: tuple[TreeEdge, ...]
    tree_parent: tuple[int, ...]  # per link index: index of the edge placing it, -1 for ground
    cut_joints: tuple[int, ...]
    loops: tuple[Loop, ...]


def _check_names(links, joints, ground):
    lnames = [l.name for l in links]
    for kind, names in (("links", lnames), ("joints", [j.name for j in joints])):
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ConfigError(f"{kind}: duplicate name(s) {dup}")
    if ground not in lnames:
        raise ConfigError(f"ground: link '{ground}' does not exist; links: {lnames}")
    if links[lnames.index(ground)].is_flexible:
        raise ConfigError(f"link '{ground}': the ground link must be rigid")


def _check_joints(links, joints):
    by_name = {l.name: l for l in links}
    seen: dict[frozenset, str] = {}
    for j in joints:
        for side, ln, fn in (("parent", j.parent, j.parent_frame), ("child", j.child, j.child_frame)):
            if ln not in by_name:
                raise ConfigError(f"joint '{j.name}': {side}: link '{ln}' does not exist; "
                                  f"links: {sorted(by_name)}")
            try:
                by_name[ln].frame(fn)
            except ConfigError as exc:
                raise ConfigError(f"joint '{j.name}': {side}_frame: {exc}") from None
        if j.parent == j.child:
            raise ConfigError(f"joint '{j.name}': parent and child are the same link '{j.parent}'")
        key = frozenset({(j.parent, j.parent_frame), (j.child, j.child_frame)})
        if key in seen:
            raise ConfigError(f"joints '{seen[key]}' and '{j.name}' connect the same frames "
                              f"{j.parent}.{j.parent_frame} and {j.child}.{j.child_frame}; "
                              "combine them into one joint of the right type")
        seen[key] = j.name


def _spanning_tree(links, joints, ground):
    index = {l.name: i for i, l in enumerate(links)}
    incident: list[list[int]] = [[] for _ in links]
    for k, j in enumerate(joints):
        incident[index[j.parent]].append(k)
        incident[index[j.child]].append(k)
    root = index[ground]
    placed, edges, used = {root: -1}, [], set()
    queue = deque([root])
    while queue:
        x = queue.popleft()
        for k in incident[x]:
            j = joints[k]
            forward = index[j.parent] == x
            y = index[j.child] if forward else index[j.parent]
            y_frame = j.child_frame if forward else j.parent_frame
            if y in placed or not links[y].frame(y_frame).is_constant:
                continue
            placed[y] = len(edges)
            edges.append(TreeEdge(k, x, y, forward))
            used.add(k)
            queue.append(y)
    return placed, edges, used, incident


def _unplaced_error(links, joints, placed, incident, ground):
    names = [l.name for l in links]
    stack = [names.index(ground)]
    reach = set(stack)
    while stack:
        x = stack.pop()
        for k in incident[x]:
            for y in (names.index(joints[k].parent), names.index(joints[k].child)):
                if y not in reach:
                    reach.add(y)
                    stack.append(y)
    lost = [names[i] for i in range(len(links)) if i not in reach]
    if lost:
        raise KinematicsError(f"links not connected to ground '{ground}': {lost}; "
                              "add the joints that attach them")
    stuck = [names[i] for i in range(len(links)) if i not in placed]
    raise KinematicsError(
        f"flexible link(s) {stuck} can only be reached through frames that move with their "
        "modes; attach one joint of each at its body (reference) frame")


def _path_to_root(link: int, edges, tree_parent) -> list[int]:
    path = []
    while tree_parent[link] >= 0:
        e = edges[tree_parent[link]]
        path.append(tree_parent[link])
        link = e.frm
    return path


def _loops(links, joints, edges, tree_parent, cut) -> tuple[Loop, ...]:
    index = {l.name: i for i, l in enumerate(links)}
    loops = []
    for n, k in enumerate(cut):
        pa = _path_to_root(index[joints[k].parent], edges, tree_parent)
        pb = _path_to_root(index[joints[k].child], edges, tree_parent)
        common = set(pa) & set(pb)
        path = [e for e in pa if e not in common] + [e for e in pb if e not in common][::-1]
        ljoints = tuple(edges[e].joint for e in path) + (k,)
        llinks = {index[joints[k].parent], index[joints[k].child]}
        for e in path:
            llinks |= {edges[e].frm, edges[e].to}
        loops.append(Loop(f"L{n + 1}", k, ljoints, tuple(sorted(llinks))))
    return tuple(loops)


def build_topology(links: tuple[Link, ...], joints: tuple[Joint, ...], ground: str) -> Topology:
    """Check names and frames, build the spanning tree and the independent loops.

    Raises
    ------
    ConfigError
        Duplicate names, a missing ground link, link or frame, a joint
        between a link and itself, two joints between the same frames.
    KinematicsError
        Links not connected to ground, or a flexible link that cannot be
        entered through a non-deforming frame.
    """
    _check_names(links, joints, ground)
    _check_joints(links, joints)
    placed, edges, used, incident = _spanning_tree(links, joints, ground)
    if len(placed) < len(links):
        _unplaced_error(links, joints, placed, incident, ground)
    tree_parent = tuple(placed[i] for i in range(len(links)))
    order = [ground] + [links[e.to].name for e in edges]
    cut = tuple(k for k in range(len(joints)) if k not in used)
    return Topology(tuple(order), tuple(edges), tree_parent, cut,
                    _loops(links, joints, edges, tree_parent, cut))
