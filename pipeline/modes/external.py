"""Clamped modes computed by another FE code, as the link's modal basis.

A company that has computed a link's clamped modes in its own FE code (and checked them
there) brings them with the mesh they belong to: CalculiX's ``.frd`` result file of a
``*FREQUENCY`` step clamped at the reference interface's nodes, with ``*NODE FILE`` ``U``
(the shapes) and, optionally, ``*EL FILE`` ``S`` (the stresses of each mode at the nodes).
The reduction then uses these shapes instead of solving its own eigenproblem; the
invariants, frames and everything downstream come from them as from its own.

What is checked, because a mode file is easily the wrong one:

* its nodes are the mesh's: the file's node numbers are those of the FE input (``*NODE``
  of the mesh file), and its coordinates (6 printed digits) lie on the mesh's points;
* each shape holds the reference interface still (clamped there) and moves every other
  rigid (RBE2) interface rigidly;
* each shape is a mode of this link's own K and M: its Rayleigh quotient gives the file's
  frequency within :data:`FREQUENCY_RTOL` (another mesh, material, unit or clamp does not).

The shapes are re-normalised to the link's own mass matrix (Phi^T M Phi = I, symmetric
orthonormalisation Phi = U W: the file's 6 printed digits leave them orthogonal to ~1e-5
only), and the modal stiffness is the file's eigenvalues carried along, W^T diag(omega^2) W:
the FE code's model, as an MNF or a superelement brings it. (The Rayleigh matrix of the
printed shapes would be ~1e-5 stiff: their rounding is noise in every mode of the mesh.)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from pipeline.core.errors import ConfigError
from pipeline.fem.interfaces import TiedModel
from pipeline.fem.model import FemModel
from pipeline.modes.basis import ModalBasis, frequencies_from_eigenvalues, sign_flips

__all__ = ["FREQUENCY_RTOL", "ExternalModes", "external_basis", "mode_stresses",
           "read_frd"]

#: the largest relative difference between a file mode's frequency and its Rayleigh
#: quotient on the link's own K and M (the two codes' elements agree to ~1e-5 on the
#: modes a link keeps; another model is off by more)
FREQUENCY_RTOL = 1e-3
#: CalculiX's component order of a stress tensor in .frd files, as indices of ours
#: (xx, yy, zz, yz, xz, xy): theirs is xx, yy, zz, xy, yz, zx
_FRD_TO_VOIGT = np.array([0, 1, 2, 4, 5, 3])


@dataclass(frozen=True)
class ExternalModes:
    """The modes of a result file, in its own units and node numbers.

    frequencies_hz (m,); node_ids (n,); coords (n, 3) in the file's length unit;
    shapes (m, n, 3) displacements; stresses (m, n, 6) Voigt (xx, yy, zz, yz, xz, xy) in
    the file's stress unit, or None; path the file.
    """

    frequencies_hz: np.ndarray
    node_ids: np.ndarray
    coords: np.ndarray
    shapes: np.ndarray
    stresses: np.ndarray | None
    path: Path


def _rows(lines: list[str], k: int, width: int, where: str) -> tuple[dict, int]:
    """{node id: values} of the ' -1' records from line k to the block's ' -3'."""
    out = {}
    while k < len(lines) and not lines[k].startswith(" -3"):
        line = lines[k]
        if line.startswith(" -1"):
            try:
                out[int(line[3:13])] = [float(line[13 + 12 * i: 25 + 12 * i])
                                        for i in range(width)]
            except ValueError:
                raise ConfigError(f"{where}:{k + 1}: expected a node and {width} values, got "
                                  f"{line.strip()[:60]!r}") from None
        k += 1
    return out, k + 1


def read_frd(path: Path) -> ExternalModes:
    """The modes of a CalculiX ``.frd`` (ASCII) result file of a ``*FREQUENCY`` step.

    Raises ConfigError naming the file (and line) when it is missing, has no node block,
    no mode with displacements, or a malformed record.
    """
    where = str(path)
    if not path.is_file():
        raise ConfigError(f"{where}: no such file")
    lines = path.read_text(errors="replace").splitlines()
    coords, freqs, disp, stress = None, [], [], []
    k, current = 0, None
    while k < len(lines):
        line = lines[k]
        head = line.split()[0] if line.strip() else ""
        if head == "2C" and coords is None:
            coords, k = _rows(lines, k + 1, 3, where)
            continue
        if head == "100CL":
            parts = line.split()
            try:
                current = float(parts[2])
            except (IndexError, ValueError):
                raise ConfigError(f"{where}:{k + 1}: expected a result header with its "
                                  f"frequency, got {line.strip()[:60]!r}") from None
            k += 1
            continue
        if line.startswith(" -4"):
            name = line[3:].split()[0].upper()
            if name in ("DISP", "STRESS") and current is not None:
                width = 3 if name == "DISP" else 6
                rows, k = _rows(lines, k + 1, width, where)
                if name == "DISP":
                    freqs.append(current)
                    disp.append(rows)
                else:
                    stress.append(rows)
                continue
        k += 1
    if coords is None:
        raise ConfigError(f"{where}: no node block (2C): not a CalculiX .frd result file?")
    if not disp:
        raise ConfigError(f"{where}: no mode shapes (DISP): give *NODE FILE with U in the "
                          "*FREQUENCY step")
    ids = np.array(sorted(coords), dtype=np.int64)
    xyz = np.array([coords[i] for i in ids])

    def table(blocks, width):
        out = np.zeros((len(blocks), ids.size, width))
        for m, rows in enumerate(blocks):
            for j, i in enumerate(ids):
                if i in rows:
                    out[m, j] = rows[i]
        return out

    stresses = None
    if stress and len(stress) == len(disp):
        stresses = table(stress, 6)[..., _FRD_TO_VOIGT]
    return ExternalModes(np.array(freqs), ids, xyz, table(disp, 3), stresses, path)


def external_basis(model: FemModel, tied: TiedModel, reference: str, K_c: sp.spmatrix,
                   M_c: sp.spmatrix, keep: np.ndarray, modes: ExternalModes,
                   node_of_id: dict[int, int], length: float, n_modes: int | None,
                   f_max: float | None) -> tuple[ModalBasis, np.ndarray]:
    """The :class:`ModalBasis` of the file's modes on ``model``, and W (m_file, m) with
    Phi = length U_file W (what turns the file's per-mode results, e.g. its stresses, into
    the basis').

    ``node_of_id`` maps the file's node numbers to model nodes; ``length`` m per file unit;
    K_c, M_c the clamped problem's matrices on the tied coordinates ``keep`` (an RBE2
    reference's masters left out). The first ``n_modes`` modes, or those up to ``f_max``
    Hz, are used.

    Raises
    ------
    ConfigError
        Too few modes; a node of the mesh the file has not; shapes that move the
        reference, bend a rigid interface, or are no modes of this link.
    """
    where = f"link {model.name!r}: modes.file: {modes.path.name}"
    if tied.interface(reference).kind != "rbe2":
        raise ConfigError(f"{where}: modes from a file need a rigid (rbe2) reference "
                          "interface, the nodes the FE code clamped")
    f = modes.frequencies_hz
    take = np.arange(f.size) if n_modes is None else np.arange(min(n_modes, f.size))
    if f_max is not None:
        take = take[f[take] <= f_max]
    if n_modes is not None and f.size < n_modes:
        raise ConfigError(f"{where}: has {f.size} modes, modes.count asks for {n_modes}")
    if take.size == 0:
        raise ConfigError(f"{where}: no mode up to modes.f_max = {f_max:g} Hz (its first is "
                          f"{f[0]:.6g} Hz)")
    missing = np.setdiff1d(np.arange(model.n_nodes), list(node_of_id.values()))
    if missing.size:
        raise ConfigError(f"{where}: {missing.size} mesh nodes have no result in the file "
                          "(another mesh?)")
    size = float(np.ptp(model.nodes, axis=0).max()) or 1.0
    file_ids = [i for i in modes.node_ids if int(i) in node_of_id]
    rows = np.searchsorted(modes.node_ids, file_ids)
    nodes = np.array([node_of_id[int(i)] for i in file_ids])
    off = np.abs(modes.coords[rows] * length - model.nodes[nodes]).max()
    if off > 1e-4 * size:
        raise ConfigError(f"{where}: its node coordinates are up to {off:.3g} m off the mesh's "
                          "(results of another mesh, or another length unit?)")
    U = np.zeros((model.n_dof, take.size))  # m
    U[model.node_dofs[nodes]] = length * modes.shapes[take][:, rows].transpose(1, 2, 0)
    # the tied coordinates: u = T u_r in the least-squares sense, and what it leaves
    T = tied.transform
    X_r = spla.spsolve((T.T @ T).tocsc(), T.T @ U).reshape(tied.n_red, -1)
    scale = np.abs(U).max(axis=0)
    bend = np.abs(T @ X_r - U).max(axis=0) / scale
    if bend.max() > 1e-4:
        k = int(np.argmax(bend))
        raise ConfigError(f"{where}: mode {take[k] + 1} does not move the link's rigid "
                          f"interfaces rigidly (off by {bend[k]:.2g} of its largest motion): "
                          "tie them in the FE model too, or make them rbe3")
    masters = tied.master_dofs[reference]
    held = np.abs(X_r[masters[:3]]).max(axis=0) / scale
    if held.max() > 1e-4:
        k = int(np.argmax(held))
        raise ConfigError(f"{where}: mode {take[k] + 1} moves the reference interface "
                          f"{reference!r} ({held[k]:.2g} of its largest motion): the FE code's "
                          "modes must be clamped at the reference's nodes")
    X = X_r[keep]
    S = X.T @ (M_c @ X)
    rayleigh = np.einsum("im,im->m", X, K_c @ X) / np.diag(S)
    f_ray = frequencies_from_eigenvalues(rayleigh)
    dev = np.abs(f_ray / f[take] - 1.0)
    if dev.max() > FREQUENCY_RTOL:
        k = int(np.flatnonzero(dev > FREQUENCY_RTOL)[0])
        raise ConfigError(f"{where}: mode {take[k] + 1} is {f[take][k]:.6g} Hz in the file but "
                          f"{f_ray[k]:.6g} Hz on this link's own K and M: modes of another "
                          "model (mesh, material, unit or clamp)?")
    w, V = np.linalg.eigh(0.5 * (S + S.T))
    W = V @ np.diag(w ** -0.5) @ V.T  # symmetric orthonormalisation: Phi^T M Phi = I
    X_r = X_r @ W
    shapes = T @ X_r
    flips = sign_flips(shapes)
    shapes, X_r, W = shapes * flips, X_r * flips, W * flips
    # the stiffness is the file's: its eigenvalues, carried through W (a Rayleigh matrix
    # of the printed shapes would add their rounding's high-frequency content, ~1e-5)
    # (U^T K U = omega^2 U^T M U for eigenvectors U of any scale)
    stiff = (2.0 * np.pi * f[take]) ** 2 * np.diag(S)
    Kr = W.T @ (stiff[:, None] * W)
    Mr = X_r.T @ (tied.mass @ X_r)
    settings = {"reference": reference, "reference_kind": "rbe2", "clamp_method": "external",
                "n_modes": n_modes, "f_max": f_max, "craig_bampton": False,
                "cb_interfaces": [], "chord": None, "eigensolver": "none: modes from "
                f"{modes.path.name}", "factorisation": None,
                "n_dof": tied.n_dof, "n_clamped": int(keep.size),
                "external": {"file": str(modes.path), "frequencies_hz": f[take].tolist(),
                             "largest_frequency_deviation": float(dev.max()),
                             "largest_tie_residual": float(bend.max())},
                "warnings": []}
    basis = ModalBasis(frequencies_from_eigenvalues(np.diag(Kr)), shapes, X_r,
                       0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T), ("normal",) * take.size,
                       reference, settings)
    return basis, W


def mode_stresses(modes: ExternalModes, node_of_id: dict[int, int], n_nodes: int,
                  W: np.ndarray, unit: float) -> np.ndarray:
    """(m, n_nodes, 6) the file's nodal stresses of the basis' modes (W from
    :func:`external_basis`: the basis' modes are the file's combined by W), Pa (``unit``
    Pa per the file's stress unit); Voigt (xx, yy, zz, yz, xz, xy), link axes."""
    if modes.stresses is None:
        raise ConfigError(f"{modes.path}: no stresses (STRESS): give *EL FILE with S")
    ids = [i for i in modes.node_ids if int(i) in node_of_id]
    rows = np.searchsorted(modes.node_ids, ids)
    at_node = np.zeros((W.shape[0], n_nodes, 6))
    at_node[:, [node_of_id[int(i)] for i in ids]] = modes.stresses[:W.shape[0]][:, rows]
    return unit * np.einsum("fnc,fm->mnc", at_node, W)
