"""Earlier runs of a workflow, kept beside its latest one.

``output/<name>/`` always holds the latest run. When a run replaces it, the one it replaces
moves, whole and unchanged, to ``output/<name>.history/<created>/`` (its manifest's UTC
creation time, ``2026-11-27T21-58-00Z``), and the oldest kept runs go once there are more
than ``outputs.history.runs`` of them or they take more than ``outputs.history.mb``
(0 runs: none is kept). A kept run is a run folder like any: ``pipeline render`` and
``pipeline report`` take it.
"""

from __future__ import annotations

import json
import logging
import shutil
import time
from pathlib import Path

from pipeline.core.atomic import folder_bytes

logger = logging.getLogger(__name__)

__all__ = ["history_dir", "history_slot", "kept_runs", "prune_history"]

HISTORY_SUFFIX = ".history"


def history_dir(run_folder: Path) -> Path:
    """Where the earlier runs of the run folder ``output/<name>`` are kept."""
    return run_folder.with_name(run_folder.name + HISTORY_SUFFIX)


def history_slot(run_folder: Path) -> Path:
    """The (new) folder the run now in ``run_folder`` moves to when it is replaced: named by
    its manifest's creation time (else the folder's modification time), UTC."""
    stamp = None
    try:
        created = json.loads((run_folder / "manifest.json").read_text())["created"]
        stamp = time.strptime(created, "%Y-%m-%dT%H:%M:%SZ")
    except (OSError, ValueError, KeyError, TypeError):
        stamp = time.gmtime(run_folder.stat().st_mtime)
    base = history_dir(run_folder) / time.strftime("%Y-%m-%dT%H-%M-%SZ", stamp)
    slot, k = base, 1
    while slot.exists():  # two runs within a second
        slot, k = base.with_name(f"{base.name}-{k}"), k + 1
    return slot


def kept_runs(run_folder: Path) -> list[Path]:
    """The kept earlier runs of ``run_folder``, newest first."""
    folder = history_dir(run_folder)
    if not folder.is_dir():
        return []
    return sorted((p for p in folder.iterdir() if p.is_dir()), key=lambda p: p.name,
                  reverse=True)


def prune_history(run_folder: Path, runs: int, mb: float | None) -> list[Path]:
    """Remove the oldest kept runs beyond the newest ``runs`` and beyond ``mb`` MB in all
    (None: no size budget); returns the removed folders."""
    kept, removed, total = kept_runs(run_folder), [], 0
    for k, p in enumerate(kept):
        total += folder_bytes(p)
        if k >= runs or (mb is not None and total > mb * 1e6):
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
    if removed:
        logger.info("%s: %d earlier run(s) removed from its history (kept: %d runs, %s)",
                    run_folder.name, len(removed), runs,
                    "no size budget" if mb is None else f"{mb:g} MB")
    folder = history_dir(run_folder)
    if folder.is_dir() and not any(folder.iterdir()):
        folder.rmdir()
    return removed
