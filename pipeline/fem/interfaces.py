"""Interfaces of a link: where joints, springs and actuators attach.

An interface is a reference point (``origin``) with a joint frame (``axes``)
and a set of FE nodes. Two ways of tying the nodes to the point:

* ``"rbe2"`` (rigid): the nodes follow the rigid motion of 6 master DOFs at
  the origin, u_i = t + theta x (x_i - origin). The nodal DOFs are replaced
  by the master DOFs through a sparse transformation ``T`` (n_dof, n_red),
  so the tied model is K_r = T^T K T, M_r = T^T M T. This stiffens the link
  locally, like a pin in a bore.
* ``"rbe3"`` (averaging): adds no stiffness. Its reference motion is the
  least-squares rigid fit ``G`` (6, n_dof) of the nodal displacements
  (:func:`pipeline.fem.rigid_fit.rigid_fit_operator`).

For beams an interface is one node carrying 6 DOFs; when the origin is not
at the node it is attached through a rigid offset
(:func:`pipeline.fem.rigid_fit.node_offset_operator`).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
import scipy.sparse as sp

from pipeline.core.errors import ConfigError
from pipeline.core.validate import validate_array, validate_rotation
from pipeline.fem.model import FemModel
from pipeline.fem.rigid_fit import node_offset_operator, rigid_fit_operator

logger = logging.getLogger(__name__)

KINDS = ("rbe2", "rbe3")


@dataclass(frozen=True)
class Interface:
    """A reference point with a joint frame, tied to FE nodes.

    Attributes
    ----------
    name : str
    origin : (3,) reference point in the link frame, m.
    axes : (3, 3) columns = joint frame x, y, z in the link frame (z = joint axis).
    kind : "rbe2" (rigid) or "rbe3" (averaging).
    nodes : (k,) sorted node ids of the FemModel (k = 1 for beams).
    """

    name: str
    origin: np.ndarray
    axes: np.ndarray
    kind: str
    nodes: np.ndarray

    @property
    def pose(self) -> np.ndarray:
        """(4, 4) homogeneous pose of the joint frame in the link frame."""
        P = np.eye(4)
        P[:3, :3] = self.axes
        P[:3, 3] = self.origin
        return P


@dataclass(frozen=True)
class InterfaceSpec:
    """What the user asks for: a selector of nodes plus the joint frame.

    ``selector`` is any object with ``select(points (n, 3), candidates (c,),
    groups) -> (k,) node ids`` (see ``pipeline.meshing.selectors``).
    """

    name: str
    selector: Any
    origin: Any
    axes: Any = None
    kind: str = "rbe2"


@dataclass(frozen=True)
class TiedModel:
    """A FemModel with its RBE2 interfaces tied (still unconstrained).

    Attributes
    ----------
    model_name : str
    n_dof : int, DOFs of the unreduced FemModel.
    interfaces : all interfaces (RBE2 and RBE3) in the order given.
    transform : (n_dof, n_red) CSR, u = T u_r.
    stiffness, mass : (n_red, n_red) CSR, T^T K T and T^T M T.
    master_dofs : RBE2 interface name -> (6,) indices into u_r of
        (tx, ty, tz, rx, ry, rz) at its origin (m, rad, link frame).
    rbe3_operators : RBE3 interface name -> (6, n_dof) CSR ``G``,
        [t; theta] = G u (reads the full, unreduced displacement).
    """

    model_name: str
    n_dof: int
    interfaces: tuple[Interface, ...]
    transform: sp.csr_matrix
    stiffness: sp.csr_matrix
    mass: sp.csr_matrix
    master_dofs: Mapping[str, np.ndarray] = field(default_factory=dict)
    rbe3_operators: Mapping[str, sp.csr_matrix] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "interfaces", tuple(self.interfaces))
        object.__setattr__(self, "master_dofs", MappingProxyType(dict(self.master_dofs)))
        object.__setattr__(self, "rbe3_operators", MappingProxyType(dict(self.rbe3_operators)))

    @property
    def n_red(self) -> int:
        return int(self.transform.shape[1])

    def interface(self, name: str) -> Interface:
        """The interface called ``name``; ConfigError lists the known ones."""
        for itf in self.interfaces:
            if itf.name == name:
                return itf
        raise ConfigError(f"link {self.model_name!r}: no interface {name!r}; "
                          f"available: {[i.name for i in self.interfaces]}")


def resolve_interfaces(
    model: FemModel,
    specs: Iterable[InterfaceSpec | tuple | Mapping[str, Any]],
    groups: Mapping[str, np.ndarray] | None = None,
    boundary_nodes: np.ndarray | None = None,
) -> tuple[Interface, ...]:
    """Turn interface specs into :class:`Interface` objects via their selectors.

    Parameters
    ----------
    model : FemModel
        Supplies ``nodes`` (n, 3) m and the link name for messages.
    specs : iterable
        :class:`InterfaceSpec`, tuples ``(name, selector, origin, axes, kind)``
        or mappings with those keys; ``axes`` None means the identity.
    groups : mapping, optional
        Physical-group name -> node ids (for group selectors).
    boundary_nodes : (c,) int, optional
        Candidate nodes for solids (default ``model.extras["boundary_nodes"]``,
        else all nodes). Beams always use all nodes.

    Returns
    -------
    tuple of Interface

    Raises
    ------
    ConfigError
        Duplicate names, unknown kind, bad origin/axes, a selector that
        matches nothing, a beam interface that is not exactly one node.
    """
    groups = {} if groups is None else groups
    if model.kind == "beam":
        candidates = np.arange(model.n_nodes)
    elif boundary_nodes is not None:
        candidates = np.asarray(boundary_nodes, int)
    else:
        candidates = np.asarray(model.extras.get("boundary_nodes", np.arange(model.n_nodes)), int)
    out: list[Interface] = []
    for raw in specs:
        spec = _as_spec(raw, model.name)
        where = f"link {model.name!r}: interface {spec.name!r}"
        if any(i.name == spec.name for i in out):
            raise ConfigError(f"{where}: duplicate interface name")
        nodes = _select(spec, model, candidates, groups, where)
        out.append(make_interface(model, spec.name, spec.origin, spec.axes, spec.kind, nodes))
    return tuple(out)


def make_interface(model: FemModel, name: str, origin, axes, kind: str,
                   nodes) -> Interface:
    """Validate and build one :class:`Interface` on ``model`` (see class doc)."""
    where = f"link {model.name!r}: interface {name!r}"
    if not isinstance(name, str) or not name:
        raise ConfigError(f"link {model.name!r}: interface name: expected a non-empty string, "
                          f"got {name!r}")
    if kind not in KINDS:
        raise ConfigError(f"{where}: kind: expected one of {KINDS}, got {kind!r}")
    origin = validate_array(origin, (3,), f"{where}: origin")
    axes = validate_rotation(np.eye(3) if axes is None else axes, f"{where}: axes")
    nodes = np.unique(np.asarray(nodes, dtype=np.int64).ravel())
    if nodes.size == 0:
        raise ConfigError(f"{where}: nodes: expected at least one node, got none")
    if nodes[0] < 0 or nodes[-1] >= model.n_nodes:
        raise ConfigError(f"{where}: nodes: expected ids in [0, {model.n_nodes}), "
                          f"got {nodes.min()}..{nodes.max()}")
    if model.has_rotations and nodes.size != 1:
        raise ConfigError(f"{where}: nodes: a beam interface is exactly one node, "
                          f"got {nodes.size}")
    if not model.has_rotations:
        _check_rigid_rank(model.nodes[nodes], origin, where)
    return Interface(name, origin, axes, kind, nodes)


def tie_interfaces(model: FemModel, interfaces: Iterable[Interface]) -> TiedModel:
    """Tie RBE2 interfaces rigidly (DOF elimination) and build RBE3 operators.

    Parameters
    ----------
    model : FemModel
        Free-free model, K (N/m...) and M (kg...) of shape (n_dof, n_dof).
    interfaces : iterable of Interface
        Names must be unique; RBE2 node sets must be disjoint.

    Returns
    -------
    TiedModel
        Independent DOFs keep their order and come first in u_r, then 6
        master DOFs per RBE2 interface in the order given.

    Raises
    ------
    ConfigError
        Duplicate names or RBE2 interfaces sharing nodes.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> x = np.array([[0., 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0]])
    >>> m = FemModel("t", "solid", x, np.arange(12).reshape(4, 3),
    ...              sp.identity(12, format="csr"), sp.identity(12, format="csr"))
    >>> itf = make_interface(m, "end", [0, 0, 0], None, "rbe2", [0, 1, 2])
    >>> tie_interfaces(m, [itf]).transform.shape
    (12, 9)
    """
    interfaces = tuple(interfaces)
    names = [i.name for i in interfaces]
    if len(set(names)) != len(names):
        raise ConfigError(f"link {model.name!r}: duplicate interface names in {names}")
    rigid = [i for i in interfaces if i.kind == "rbe2"]
    slave = [model.node_dofs[i.nodes].ravel() for i in rigid]
    all_slave = np.concatenate(slave) if slave else np.zeros(0, np.int64)
    if np.unique(all_slave).size != all_slave.size:
        raise ConfigError(f"link {model.name!r}: RBE2 interfaces "
                          f"{[i.name for i in rigid]} share nodes; a node can follow one master only")
    n_dof = model.n_dof
    independent = np.setdiff1d(np.arange(n_dof), all_slave)
    n_ind = independent.size
    rows, cols, vals = [independent], [np.arange(n_ind)], [np.ones(n_ind)]
    master_dofs = {}
    for j, itf in enumerate(rigid):
        master = n_ind + 6 * j + np.arange(6)
        master_dofs[itf.name] = master
        r, c, v = _rigid_entries(model, itf, master)
        rows.append(r), cols.append(c), vals.append(v)
    n_red = n_ind + 6 * len(rigid)
    T = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n_dof, n_red))
    if rigid:
        Tt = T.T.tocsr()
        # no re-symmetrisation: entries of untied DOFs stay bit-identical to K, M
        K_r = sp.csr_matrix(Tt @ model.stiffness @ T)
        M_r = sp.csr_matrix(Tt @ model.mass @ T)
    else:  # T = I: keep the model's own matrices bit for bit
        K_r, M_r = sp.csr_matrix(model.stiffness), sp.csr_matrix(model.mass)
    rbe3 = {i.name: interface_operator(model, i) for i in interfaces if i.kind == "rbe3"}
    logger.info("link %r: tied %d RBE2 / %d RBE3 interfaces, %d -> %d DOFs", model.name,
                len(rigid), len(rbe3), n_dof, n_red)
    return TiedModel(model.name, n_dof, interfaces, T, K_r, M_r, master_dofs, rbe3)


def interface_operator(model: FemModel, interface: Interface) -> sp.csr_matrix:
    """(6, n_dof) CSR reading [t; theta] at the interface origin off a full u.

    Solids: least-squares rigid fit over the interface nodes (exact for an
    RBE2-tied field); beams: the node's 6 DOFs with the rigid offset.
    """
    if model.has_rotations:
        n = int(interface.nodes[0])
        return node_offset_operator(model.nodes[n], model.node_dofs[n], model.n_dof,
                                    interface.origin)
    try:
        return rigid_fit_operator(model.nodes[interface.nodes], model.node_dofs[interface.nodes],
                                  model.n_dof, interface.origin)
    except ConfigError as exc:
        raise ConfigError(f"link {model.name!r}: interface {interface.name!r}: {exc}") from exc


def _rigid_entries(model: FemModel, itf: Interface, master: np.ndarray):
    """COO entries of u_slave = B_i [t; theta] for the nodes of one RBE2 interface."""
    r = model.nodes[itf.nodes] - itf.origin  # (k, 3)
    k = r.shape[0]
    B = np.zeros((k, 3, 6))
    B[:, :, :3] = np.eye(3)
    # t + theta x r = t - [r]x theta
    B[:, 0, 4], B[:, 0, 5] = r[:, 2], -r[:, 1]
    B[:, 1, 3], B[:, 1, 5] = -r[:, 2], r[:, 0]
    B[:, 2, 3], B[:, 2, 4] = r[:, 1], -r[:, 0]
    dofs = model.node_dofs[itf.nodes]
    if model.has_rotations:  # beam node: rotations equal the master rotation
        rot = np.zeros((k, 3, 6))
        rot[:, :, 3:] = np.eye(3)
        B = np.concatenate([B, rot], axis=1)
    rows = np.repeat(dofs.reshape(-1), 6)
    cols = np.tile(master, dofs.size)
    keep = B.reshape(-1) != 0.0
    return rows[keep], cols[keep], B.reshape(-1)[keep]


def _check_rigid_rank(x: np.ndarray, origin: np.ndarray, where: str) -> None:
    """Raise unless the nodes determine all 6 rigid DOFs (>= 3 non-collinear)."""
    r = x - origin
    scale = max(float(np.abs(r).max()), 1e-300)
    centred = (r - r.mean(axis=0)) / scale
    if x.shape[0] < 3 or np.linalg.matrix_rank(centred, tol=1e-9) < 2:
        raise ConfigError(f"{where}: nodes: expected at least 3 non-collinear nodes to carry "
                          f"6 rigid DOFs, got {x.shape[0]} node(s) on a line or a point")


def _select(spec: InterfaceSpec, model: FemModel, candidates: np.ndarray,
            groups: Mapping[str, np.ndarray], where: str) -> np.ndarray:
    select = getattr(spec.selector, "select", None)
    if select is None:
        raise ConfigError(f"{where}: selector: expected an object with a select() method, "
                          f"got {spec.selector!r}")
    try:
        nodes = np.asarray(select(model.nodes, candidates, groups), dtype=np.int64)
    except ConfigError as exc:
        raise ConfigError(f"{where}: selector {spec.selector!r}: {exc}; "
                          f"{mesh_extent(model.nodes)}") from exc
    if nodes.size == 0:
        raise ConfigError(f"{where}: selector {spec.selector!r} matched no nodes; "
                          f"{mesh_extent(model.nodes)}")
    return nodes


def mesh_extent(points: np.ndarray) -> str:
    """Where the mesh is, for errors about geometry: its bounding box in m (a selector that
    finds nothing is often a unit slip, such as a CAD file in millimetres read as metres)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    return "the mesh spans " + ", ".join(f"{a} [{lo[k]:.4g}, {hi[k]:.4g}]"
                                         for k, a in enumerate("xyz")) + " m"


def _as_spec(raw, link: str) -> InterfaceSpec:
    if isinstance(raw, InterfaceSpec):
        return raw
    if isinstance(raw, Mapping):
        try:
            return InterfaceSpec(**raw)
        except TypeError as exc:
            raise ConfigError(f"link {link!r}: interface spec {dict(raw)!r}: {exc}") from exc
    if isinstance(raw, (tuple, list)) and 3 <= len(raw) <= 5:
        return InterfaceSpec(*raw)
    raise ConfigError(f"link {link!r}: interface spec: expected InterfaceSpec, mapping or "
                      f"(name, selector, origin, axes, kind), got {raw!r}")
