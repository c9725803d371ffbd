"""Save and load :class:`ReducedLink` artifacts (``.npz``) with integrity checks.

The file carries a format version and a SHA-256 digest of everything the loader
uses (the arrays and the header's names, kinds and provenance); a truncated,
corrupted, edited or foreign file raises :class:`ArtifactError` and is never
half-used. Writes are atomic.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from pathlib import Path

import numpy as np

from pipeline.core.atomic import save_npz_atomic
from pipeline.core.errors import ArtifactError
from pipeline.invariants.reduced_link import FrameModes, ReducedLink

FORMAT = "pipeline.ReducedLink"
FORMAT_VERSION = 2  # 2: the digest covers the header

_ARRAYS = ("body_pose", "C", "Cp", "Cpp", "modal_stiffness", "modal_mass",
           "frequencies_hz", "nodes", "cells", "surface", "mode_shapes")
_OPTIONAL = ("geometric_stiffness", "force_geometric_stiffness",
             "inertia_geometric_stiffness", "stress_modes")  # absent when not computed


def _digest(arrays: dict[str, np.ndarray], header: dict) -> str:
    """SHA-256 of the arrays and of the header's fields other than the digest itself."""
    h = hashlib.sha256()
    fields = {k: v for k, v in header.items() if k != "digest"}
    h.update(json.dumps(fields, sort_keys=True, default=str).encode())
    for key in sorted(arrays):
        a = np.ascontiguousarray(arrays[key])
        h.update(key.encode())
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _to_arrays(link: ReducedLink) -> dict[str, np.ndarray]:
    arrays = {k: np.asarray(getattr(link, k)) for k in _ARRAYS}
    for key in _OPTIONAL:
        if getattr(link, key).size:
            arrays[key] = np.asarray(getattr(link, key))
    arrays["frame_pose"] = np.array([f.pose for f in link.frames]).reshape(-1, 4, 4)
    arrays["frame_phi"] = np.array([f.phi for f in link.frames]).reshape(
        len(link.frames), link.n_modes, 3)
    arrays["frame_psi"] = np.array([f.psi for f in link.frames]).reshape(
        len(link.frames), link.n_modes, 3)
    return arrays


def save_reduced_link(link: ReducedLink, path: str | Path) -> Path:
    """Write ``link`` to ``path`` (.npz) atomically; return the path."""
    arrays = _to_arrays(link)
    header = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "name": link.name,
        "kind": link.kind,
        "mode_kinds": list(link.mode_kinds),
        "frames": [[f.name, f.kind] for f in link.frames],
        "meta": dict(link.meta),
    }
    header["digest"] = _digest(arrays, json.loads(json.dumps(header, default=str)))
    return save_npz_atomic(path, header=np.array(json.dumps(header)), **arrays)


#: what reading a damaged or foreign .npz raises
_UNREADABLE = (zipfile.BadZipFile, OSError, ValueError, KeyError, EOFError)


def read_header(path: str | Path) -> dict:
    """The header of an artifact (name, kind, frames, meta, ...) without reading or checking
    its arrays (a listing of the cache need not load every link); ArtifactError if it
    cannot be read."""
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            header = json.loads(str(data["header"]))
    except _UNREADABLE as exc:
        raise ArtifactError(f"{path}: unreadable reduced-link artifact ({exc})") from exc
    if header.get("format") != FORMAT:
        raise ArtifactError(f"{path}: not a {FORMAT} file")
    return header


def load_reduced_link(path: str | Path) -> ReducedLink:
    """Read a :class:`ReducedLink`; raise ArtifactError if it is not intact."""
    path = Path(path)
    if not path.is_file():
        raise ArtifactError(f"{path}: reduced-link artifact not found")
    try:
        with np.load(path, allow_pickle=False) as data:
            header = json.loads(str(data["header"]))
            arrays = {k: data[k] for k in data.files if k != "header"}
    except _UNREADABLE as exc:
        raise ArtifactError(f"{path}: unreadable reduced-link artifact ({exc})") from exc
    if header.get("format") != FORMAT or header.get("version") != FORMAT_VERSION:
        raise ArtifactError(f"{path}: not a {FORMAT} v{FORMAT_VERSION} file")
    if _digest(arrays, header) != header.get("digest"):
        raise ArtifactError(f"{path}: content digest mismatch (corrupted artifact)")
    frames = tuple(
        FrameModes(name, arrays["frame_pose"][i], arrays["frame_phi"][i],
                   arrays["frame_psi"][i], kind)
        for i, (name, kind) in enumerate(header["frames"])
    )
    return ReducedLink(
        name=header["name"], kind=header["kind"], mode_kinds=tuple(header["mode_kinds"]),
        frames=frames, meta=header["meta"], **{k: arrays[k] for k in _ARRAYS},
        **{k: arrays.get(k) for k in _OPTIONAL},
    )
