"""A reduced link in an open, documented, versioned HDF5 file (``docs/hdf5_format.md``).

The ``.npz`` artifact is this tool's cache; the HDF5 file is for other tools: every
array under a name that says what it is, with its units as an attribute, readable with
any HDF5 library (h5py, MATLAB's ``h5read``, HDF5 for C++ or Julia). Version 1 of the
format ``flexmech.ReducedLink`` is laid out as

    /                       attrs: format, format_version, name, kind, units, pipeline
    /body_pose              (4, 4)         body frame in the geometry frame
    /mass/C                 (4, 4)         int rho r r^T dV
    /mass/Cp                (m, 4, 4)      C'_a = int rho r phi_a^T dV
    /mass/Cpp               (m, m, 4, 4)   C''_ab = int rho phi_a phi_b^T dV
    /modes/stiffness        (m, m)         Phi^T K Phi
    /modes/mass             (m, m)         Phi^T M Phi
    /modes/frequencies_hz   (m,)
    /modes/kinds            (m,)           "normal" | "constraint"
    /modes/shapes           (m, N, 3)      nodal translations per unit modal coordinate
    /modes/stress           (m, N, 6)      optional (attrs: components)
    /frames/<k>             group per frame, k = 0, 1, ... in order;
                            attrs name, kind; datasets pose (4, 4), phi (m, 3), psi (m, 3)
    /mesh/nodes             (N, 3)         body frame
    /mesh/cells             (k, p)         attrs cell_type (meshio name)
    /mesh/surface           (t, q)
    /stiffening/centrifugal (6, m, m)      optional, and force (F, 3, m, m), inertia (4, 3, m, m)
    /meta                   attrs json: provenance and settings

:func:`write_hdf5` writes it atomically; :func:`read_hdf5` reads it back into the same
:class:`ReducedLink` (a round trip is exact), refusing another format or a newer version.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pipeline import __version__
from pipeline.core.atomic import atomic_path
from pipeline.core.errors import ArtifactError, ConfigError
from pipeline.invariants.reduced_link import FrameModes, ReducedLink

__all__ = ["FORMAT", "FORMAT_VERSION", "read_hdf5", "write_hdf5"]

FORMAT = "flexmech.ReducedLink"
FORMAT_VERSION = 1

#: dataset path -> (ReducedLink field, units)
_REQUIRED = {
    "body_pose": ("body_pose", "m (homogeneous 4x4)"),
    "mass/C": ("C", "kg, kg m, kg m^2"),
    "mass/Cp": ("Cp", "kg m per unit modal coordinate"),
    "mass/Cpp": ("Cpp", "kg per unit modal coordinate squared"),
    "modes/stiffness": ("modal_stiffness", "N m / unit^2 (modal)"),
    "modes/mass": ("modal_mass", "kg / unit^2 (modal)"),
    "modes/frequencies_hz": ("frequencies_hz", "Hz"),
    "modes/shapes": ("mode_shapes", "m per unit modal coordinate"),
    "mesh/nodes": ("nodes", "m, body frame"),
    "mesh/cells": ("cells", "node indices (0-based)"),
    "mesh/surface": ("surface", "node indices (0-based)"),
}
_OPTIONAL = {
    "modes/stress": ("stress_modes", "Pa (solids) or N, N m (beams) per unit modal coordinate"),
    "stiffening/centrifugal": ("geometric_stiffness",
                               "N m s^2 per unit product of body angular velocities"),
    "stiffening/force": ("force_geometric_stiffness", "N m per N at each frame"),
    "stiffening/inertia": ("inertia_geometric_stiffness", "per unit inertia case"),
}


def _h5py():
    try:
        import h5py
    except ImportError:
        raise ConfigError("HDF5 export needs h5py: pip install 'flexmech-pipeline[hdf5]'") \
            from None
    return h5py


def write_hdf5(link: ReducedLink, path: str | Path) -> Path:
    """Write ``link`` to ``path`` (HDF5, format ``flexmech.ReducedLink`` v1), atomically."""
    h5py = _h5py()
    path = Path(path)
    try:
        with atomic_path(path) as tmp:
            _write(h5py, link, tmp)
    except OSError as exc:  # an unwritable folder: the target named, not the temporary file
        raise ArtifactError(f"{path}: cannot write the HDF5 file here "
                            f"({exc.strerror or exc})") from None
    return path


def _write(h5py, link: ReducedLink, path: Path) -> None:
    """The datasets and attributes of the format (module docstring) into a new file."""
    with h5py.File(path, "w") as f:
        f.attrs.update({"format": FORMAT, "format_version": FORMAT_VERSION,
                        "name": link.name, "kind": link.kind, "units": "SI",
                        "pipeline": __version__})
        for key, (attr, units) in {**_REQUIRED, **_OPTIONAL}.items():
            a = np.asarray(getattr(link, attr))
            if key in _OPTIONAL and not a.size:
                continue
            ds = f.create_dataset(key, data=a, compression="gzip" if a.size > 4096 else None)
            ds.attrs["units"] = units
        f["mesh/cells"].attrs["cell_type"] = _cell_type(link)
        f.create_dataset("modes/kinds", data=np.array(link.mode_kinds, dtype="S"))
        if link.stress_modes.size:
            f["modes/stress"].attrs["components"] = (
                "xx, yy, zz, yz, xz, xy (body axes)" if link.kind == "solid"
                else "N, Vy, Vz, T, My, Mz (element axes)")
        frames = f.create_group("frames")
        for k, fr in enumerate(link.frames):
            g = frames.create_group(str(k))
            g.attrs.update({"name": fr.name, "kind": fr.kind})
            g.create_dataset("pose", data=fr.pose)
            g.create_dataset("phi", data=np.asarray(fr.phi).reshape(link.n_modes, 3))
            g.create_dataset("psi", data=np.asarray(fr.psi).reshape(link.n_modes, 3))
        f.create_group("meta").attrs["json"] = json.dumps(dict(link.meta), default=str)


def _cell_type(link: ReducedLink) -> str:
    if link.kind == "beam":
        return "line"
    return {10: "tetra10", 4: "tetra"}.get(int(link.cells.shape[1]), "unknown")


def read_hdf5(path: str | Path) -> ReducedLink:
    """The :class:`ReducedLink` of an HDF5 file written by :func:`write_hdf5` (or by
    another tool to the same format); ArtifactError for anything else."""
    h5py = _h5py()
    path = Path(path)
    if not path.is_file():
        raise ArtifactError(f"{path}: no such file")
    try:
        with h5py.File(path, "r") as f:
            fmt, version = f.attrs.get("format"), f.attrs.get("format_version")
            if fmt != FORMAT:
                raise ArtifactError(f"{path}: not a {FORMAT} file (format {fmt!r})")
            if version is None or int(version) > FORMAT_VERSION:
                raise ArtifactError(f"{path}: {FORMAT} version {version} is newer than this "
                                    f"tool reads ({FORMAT_VERSION}); update the pipeline")
            missing = [k for k in _REQUIRED if k not in f]
            if missing:
                raise ArtifactError(f"{path}: missing datasets {missing}")
            fields = {attr: f[key][()] for key, (attr, _) in _REQUIRED.items()}
            fields.update({attr: f[key][()] for key, (attr, _) in _OPTIONAL.items() if key in f})
            kinds = tuple(k.decode() for k in f["modes/kinds"][()])
            frames = tuple(
                FrameModes(str(g.attrs["name"]), g["pose"][()], g["phi"][()], g["psi"][()],
                           str(g.attrs["kind"]))
                for g in (f["frames"][str(k)] for k in range(len(f["frames"]))))
            meta = json.loads(f["meta"].attrs["json"])
            name, kind = str(f.attrs["name"]), str(f.attrs["kind"])
    except OSError as exc:
        raise ArtifactError(f"{path}: unreadable HDF5 file ({exc})") from None
    return ReducedLink(name=name, kind=kind, mode_kinds=kinds, frames=frames, meta=meta,
                       **fields)
