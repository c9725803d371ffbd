"""The meshing process of :mod:`pipeline.meshing.budget`:
``python -m pipeline.meshing.mesh_child FOLDER``.

Reads ``FOLDER/request.json``, limits its own address space and file sizes (this process
only), meshes, and writes ``FOLDER/mesh.npz`` and ``FOLDER/status.json`` (the outcome and
the log records for the parent to re-emit). Not imported by the package.
"""

from __future__ import annotations

import json
import logging
import os
import resource
import sys
from pathlib import Path

from pipeline.core.resources import address_space, peak_address_space
from pipeline.meshing.budget import as_error, check_mesh_size, save_mesh


class _Records(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.records: list[dict] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append({"name": record.name, "level": record.levelno,
                             "message": record.getMessage()})


def _limit(memory: int | None, file_bytes: int) -> int:
    """Set the limits; return the address space of the loaded program, bytes."""
    # the budget is the memory meshing takes beyond the loaded program (python, numpy,
    # gmsh and OpenCASCADE map ~1 GB of address space before any work)
    import gmsh  # noqa: F401

    base = address_space()
    if memory is not None and base:  # (no /proc: no address-space limit, the rest holds)
        resource.setrlimit(resource.RLIMIT_AS, (base + memory, base + memory))
    resource.setrlimit(resource.RLIMIT_FSIZE, (file_bytes, file_bytes))
    return base


def main(folder: Path) -> int:
    request = json.loads((folder / "request.json").read_text())
    memory = request["memory"]
    base = _limit(memory, request["file_bytes"])
    records = _Records()
    root = logging.getLogger("pipeline")
    root.setLevel(request["log_level"])
    root.addHandler(records)
    status: dict
    try:
        from pipeline.meshing.geometry import SolidGeometry
        from pipeline.meshing.gmsh_build import build_solid

        name = request["name"]
        geometry = SolidGeometry(request["recipe"], request["params"], request["mesh_size"],
                                 request["order"], request["path"])
        mesh = build_solid(geometry, name, request["options"], memory)
        check_mesh_size(mesh, memory, f"link {name!r}")
        status = {"outcome": "ok", "mesh": save_mesh(mesh, folder / "mesh.npz")}
    except BaseException as exc:  # noqa: BLE001 - every failure goes back to the parent
        # an allocation refused by the limit reaches Python as MemoryError, gmsh's
        # std::bad_alloc, or an empty gmsh error. A growing array that cannot grow holds
        # a third or more of what it asked for (old block + new block of twice its size),
        # so a peak beyond a quarter of the budget says the budget was the cause
        try:
            near = memory is not None and peak_address_space() - base > 0.25 * memory
        except MemoryError:  # not even /proc's few lines fit: the budget is spent
            near = memory is not None
        status = as_error(exc, near_limit=near)
    status["records"] = records.records
    tmp = folder / "status.json.tmp"
    tmp.write_text(json.dumps(status))
    os.replace(tmp, folder / "status.json")
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1])))
