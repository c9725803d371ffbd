"""What meshing one link may take, and meshing held to it in a process of its own.

gmsh cannot be interrupted in-process (its parser and OCC run in C++ without returning to
Python), so a ``.geo`` script whose loop bound is an expression, a script that meshes
itself finely, or an OCC crash on damaged CAD would hang, exhaust or end the whole run.
A solid link is therefore meshed by ``python -m pipeline.meshing.mesh_child`` in a private
temporary folder: stdin closed, address space and file sizes limited by the kernel, killed
at its time limit; its result comes back as an ``.npz`` of plain arrays (no pickle) and
its log records are re-emitted here. A failure is one :class:`MeshError` naming the link,
the budget that stopped it and what to change.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError, MeshError, PipelineError
from pipeline.meshing.geometry import SolidGeometry
from pipeline.meshing.mesh_data import MeshData

logger = logging.getLogger(__name__)

#: default wall time of one link's meshing, s (the 495 k-DOF bar meshes in ~20 s here)
MESH_SECONDS = 600.0
#: bytes of the result file per mesh node allowed (points 24, P2 tetrahedra ~40, boundary
#: and groups less): with :data:`BYTES_PER_DOF` this bounds the file by what the memory
#: budget lets the reduction take
RESULT_BYTES_PER_NODE = 256
#: the smallest file-size limit, bytes (small meshes and gmsh's messages)
MIN_FILE_BYTES = 64 * 2**20
_ERRORS = {"ConfigError": ConfigError, "MeshError": MeshError}


@dataclass(frozen=True)
class MeshBudget:
    """What meshing one link may take.

    Parameters
    ----------
    seconds : float
        Wall time, s, after which the meshing process is killed.
    memory : float, optional
        Address space of the meshing process, bytes; also bounds the mesh it may return
        (its reduction needs ~``BYTES_PER_DOF`` per degree of freedom). Default: the
        memory available when meshing starts.
    """

    seconds: float = MESH_SECONDS
    memory: float | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.seconds, (int, float)) and 0 < self.seconds < float("inf")):
            raise ConfigError(f"geometry.time_limit: expected a positive number of seconds, "
                              f"got {self.seconds!r}")
        if self.memory is not None and not (isinstance(self.memory, (int, float))
                                            and 0 < self.memory < float("inf")):
            raise ConfigError(f"geometry.memory_limit: expected a positive size, "
                              f"got {self.memory!r}")

    def memory_bytes(self) -> int | None:
        """The memory budget in bytes (None: the system does not say what is available)."""
        from pipeline.core.resources import available_memory

        return int(self.memory) if self.memory is not None else available_memory()


def mesh_in_child(geometry: SolidGeometry, name: str, options: Mapping[str, float],
                  budget: MeshBudget) -> MeshData:
    """Mesh ``geometry`` in a child process held to ``budget`` (see the module docstring).

    Raises
    ------
    ConfigError, MeshError
        As raised in the child (same kind and message), or MeshError for a budget the
        child exceeded or a child that died.
    """
    where = f"link {name!r}"
    memory = budget.memory_bytes()
    file_bytes = MIN_FILE_BYTES if memory is None else \
        max(MIN_FILE_BYTES, int(RESULT_BYTES_PER_NODE * max_nodes(memory)))
    request = {"name": name, "recipe": geometry.recipe, "params": dict(geometry.params),
               "mesh_size": geometry.mesh_size, "order": geometry.order,
               "path": None if geometry.path is None else str(geometry.path),
               "options": dict(options), "memory": memory, "file_bytes": file_bytes,
               "log_level": logging.getLogger("pipeline").getEffectiveLevel()}
    with tempfile.TemporaryDirectory(prefix="pipeline-mesh-") as tmp:
        folder = Path(tmp)
        (folder / "request.json").write_text(json.dumps(request))
        with open(folder / "messages.txt", "wb") as out:
            try:
                proc = subprocess.run([sys.executable, "-m", "pipeline.meshing.mesh_child",
                                       str(folder)], stdin=subprocess.DEVNULL, stdout=out,
                                      stderr=out, timeout=budget.seconds, env=_child_env(),
                                      cwd=folder, check=False)
            except subprocess.TimeoutExpired:
                raise MeshError(
                    f"{where}: meshing was stopped after its time limit of "
                    f"{budget.seconds:g} s: coarsen mesh_size, simplify the geometry, or "
                    "raise geometry.time_limit") from None
        status = _read_status(folder / "status.json")
        for record in status.get("records", []):
            logging.getLogger(record["name"]).log(record["level"], "%s", record["message"])
        if proc.returncode < 0 or status.get("outcome") is None:
            raise MeshError(_no_result(where, proc.returncode, memory, file_bytes,
                                       _tail(folder / "messages.txt")))
        if status["outcome"] == "memory":
            raise MeshError(_out_of_memory(where, memory))
        if status["outcome"] == "error":
            raise _ERRORS.get(status["kind"], MeshError)(status["message"])
        result = folder / "mesh.npz"
        if result.stat().st_size > file_bytes:  # the kernel's limit makes this a backstop
            raise MeshError(f"{where}: the meshing process returned "
                            f"{result.stat().st_size / 2**20:.0f} MB, beyond its output "
                            f"budget of {file_bytes / 2**20:.0f} MB")
        return load_mesh(result, status["mesh"])


#: tetrahedra per (volume / mesh_size^3) (6.1-6.3 on a 0.4 m bar, 7.0 on the lift arm, 11
#: on a slender bar: below the low end, so that an estimate never refuses a mesh that fits)
TETS_PER_SIZE_CUBE = 5.0
#: memory of the reduction per FE degree of freedom, bytes (495 000 DOF took 7.6 GB:
#: ~15 kB; the low end again)
BYTES_PER_DOF = 10_000


def estimated_dof(volume: float, size: float, order: int) -> float:
    """Degrees of freedom of a solid mesh of ``volume`` m^3 at ``size`` m, before meshing
    (a low estimate): ~5 tetrahedra per size^3; P2 meshes have ~1.9-2.1 nodes per
    tetrahedron, P1 ~1/5."""
    tets = TETS_PER_SIZE_CUBE * volume / size ** 3
    return 3.0 * tets * (1.9 if order == 2 else 0.2)


def check_mesh_budget(volume: float, size: float, order: int, where: str,
                      available: int | None = None) -> None:
    """MeshError, before gmsh meshes, when the estimated mesh would need more memory than
    ``available`` bytes (the link's memory budget; default: what the system has
    available)."""
    from pipeline.core.resources import available_memory

    dof = estimated_dof(volume, size, order)
    need = dof * BYTES_PER_DOF
    have = available_memory() if available is None else available
    if have is not None and need > have:
        raise MeshError(f"{where}: mesh_size {size:g} m on a volume of {volume:.4g} m^3 would "
                        f"give ~{dof:.3g} degrees of freedom and need ~{need / 2**30:.3g} GB; "
                        f"the memory budget is {have / 2**30:.3g} GB (geometry.memory_limit; "
                        "default: the memory available): use a larger mesh_size")


def max_nodes(memory: float) -> float:
    """Mesh nodes whose reduction fits in ``memory`` bytes."""
    return memory / (3 * BYTES_PER_DOF)


def check_mesh_size(mesh: MeshData, memory: float | None, where: str) -> None:
    """MeshError when the reduction of ``mesh`` would not fit in ``memory`` bytes (a
    ``.geo`` script's own sizes can make a mesh far finer than ``mesh_size`` promised)."""
    if memory is not None and mesh.n_points > max_nodes(memory):
        need = 3 * mesh.n_points * BYTES_PER_DOF
        raise MeshError(f"{where}: the mesh has {mesh.n_points} nodes (finer than mesh_size "
                        f"asked: the geometry's own sizes?); its reduction needs "
                        f"~{need / 2**30:.3g} GB, more than the memory budget of "
                        f"{_gb(memory)} GB: coarsen the mesh")


def save_mesh(mesh: MeshData, path: Path) -> dict[str, Any]:
    """Write ``mesh``'s arrays to ``path`` (.npz, no pickle); return the rest as JSON data
    with the array keys."""
    arrays: dict[str, np.ndarray] = {"points": mesh.points}
    index: dict[str, dict[str, str]] = {}
    for part in ("cells", "boundary", "groups", "cell_groups", "cad"):
        index[part] = {}
        for i, (key, value) in enumerate(getattr(mesh, part).items()):
            arrays[f"{part}_{i}"] = np.asarray(value)
            index[part][key] = f"{part}_{i}"
    np.savez(path, **arrays)
    return {"kind": mesh.kind, "order": mesh.order, "source": mesh.source, "index": index}


def load_mesh(path: Path, meta: Mapping[str, Any]) -> MeshData:
    """Inverse of :func:`save_mesh`."""
    with np.load(path, allow_pickle=False) as data:
        parts = {part: {key: data[arr] for key, arr in keys.items()}
                 for part, keys in meta["index"].items()}
        return MeshData(points=data["points"], kind=meta["kind"], order=int(meta["order"]),
                        source=meta["source"], **parts)


def _child_env() -> dict[str, str]:
    import pipeline

    root = str(Path(pipeline.__file__).resolve().parents[1])
    path = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": root + (os.pathsep + path if path else ""),
            "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def _read_status(path: Path) -> dict[str, Any]:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _out_of_memory(where: str, memory: int) -> str:
    return (f"{where}: meshing ran out of its memory budget of {_gb(memory)} GB: coarsen "
            "mesh_size, or raise geometry.memory_limit if the machine has more")


def _no_result(where: str, code: int, memory: int | None, file_bytes: int, tail: str) -> str:
    """Why a meshing process that wrote no result ended (exit code or -signal ``code``; the
    ``tail`` of its messages)."""
    if memory is not None and code > 0 and tail.rstrip().endswith("MemoryError"):
        # its own last words failed for want of memory: the budget again
        return _out_of_memory(where, memory)
    return f"{where}: {_death(code, memory, file_bytes)}{tail}"


def _death(code: int, memory: int | None, file_bytes: int) -> str:
    if code >= 0:
        return f"the meshing process ended with exit code {code} without a result"
    try:
        sig = signal.Signals(-code).name
    except ValueError:
        sig = f"signal {-code}"
    why = {"SIGKILL": "killed from outside or by the system's out-of-memory killer"
                      + ("" if memory is None else f" (memory budget {_gb(memory)} GB)"),
           "SIGXFSZ": f"it wrote more than its output budget of {file_bytes / 2**20:.0f} MB",
           "SIGSEGV": "a crash in gmsh or OpenCASCADE: damaged or unusual CAD? Try "
                      "params.heal: true, or export the part again",
           "SIGABRT": "gmsh or OpenCASCADE aborted: damaged or unusual CAD, or out of memory"
           }.get(sig, "")
    return f"the meshing process ended with {sig}" + (f" ({why})" if why else "")


def _tail(path: Path, size: int = 600) -> str:
    try:
        with open(path, "rb") as fh:
            fh.seek(max(0, path.stat().st_size - size))
            text = fh.read().decode("utf-8", "replace").strip()
    except OSError:
        return ""
    return f"; its last messages: {' | '.join(text.splitlines()[-4:])}" if text else ""


def _gb(nbytes: float) -> str:
    return f"{nbytes / 2**30:.3g}"


def as_error(exc: BaseException, near_limit: bool = False) -> dict[str, Any]:
    """The child's report of ``exc``: its kind and message, or that memory ran out (also
    a failure of gmsh itself when the process had come ``near_limit`` of its budget; the
    project's own refusals keep their message)."""
    text = str(exc)
    of_gmsh = not isinstance(exc, PipelineError) or "gmsh failed" in text
    if isinstance(exc, MemoryError) or "bad_alloc" in text or (near_limit and of_gmsh):
        return {"outcome": "memory"}
    kind = type(exc).__name__ if isinstance(exc, PipelineError) else "MeshError"
    return {"outcome": "error", "kind": kind, "message": text}
