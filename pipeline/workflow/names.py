"""Names that become paths: the run's folder, its files, and the checks that keep them apart.

A workflow's name (``name:`` or the file stem) names its folder ``output/<name>``; analysis,
case and output names name the files inside. Every one is checked before anything runs: a
plain name (no separators, no leading dot, not ``.``/``..``), not a folder the pipeline keeps
for itself, and no two outputs writing the same file (two case labels differing only in
characters a file name cannot hold, an output named like an analysis' export).
"""

from __future__ import annotations

import re
from pathlib import Path

from pipeline.core.errors import ConfigError

__all__ = ["PLAIN_NAME", "RESERVED", "check_folder_owner", "check_run_folder", "planned_files",
           "run_name", "slug"]

#: the file that says what wrote an output folder: a workflow run or a study
OWNER_FILES = {"run": "manifest.json", "study": "study.json"}

#: a name that is safe as one path component on every platform
PLAIN_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_\-]*$")
#: folders of ``output/`` that belong to the pipeline (the reduced-link cache, benchmarks)
RESERVED = frozenset({"links", "bench"})


def slug(text: str) -> str:
    """File-name-safe form of a case label ("3 modes" -> "3_modes")."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_.") or "case"


def run_name(spec_name: str | None, path: Path, where: str) -> str:
    """The run's folder name: ``spec_name`` or the file stem, checked to be a plain name
    that is not reserved. ``where``: ``file:line: name`` for the error."""
    name = spec_name if spec_name is not None else path.stem
    source = "name" if spec_name is not None else f"the file name {path.name!r} (no name:)"
    if not PLAIN_NAME.fullmatch(name):
        raise ConfigError(f"{where}: {source} cannot name the output folder: expected letters, "
                          f"digits, '_' or '-' (starting with a letter or '_'), got {name!r}; "
                          "give the workflow a name:")
    if name in RESERVED:
        raise ConfigError(f"{where}: {source}: {name!r} is a folder the pipeline keeps in "
                          f"output/ ({', '.join(sorted(RESERVED))}); choose another name")
    return name


def check_run_folder(final: Path, cache_dir: Path) -> None:
    """The run's folder must neither be nor hold the reduced-link cache (a run replaces its
    whole folder)."""
    f, c = final.resolve(), cache_dir.resolve()
    if f == c or f in c.parents:
        raise ConfigError(f"the run's folder {final} would replace the reduced-link cache "
                          f"{cache_dir}; rename the workflow or move the cache")


def check_folder_owner(folder: Path, owner: str, where: str) -> None:
    """A workflow run and a study of the same name would share ``output/<name>``: a run
    replaces its folder whole, a study keeps its table there. Refuse to write into a
    folder the other kind wrote (``owner``: "run" or "study"; ``where`` names the input)."""
    other = next(k for k in OWNER_FILES if k != owner)
    if (folder / OWNER_FILES[other]).is_file() and not (folder / OWNER_FILES[owner]).is_file():
        what = "a workflow run's results" if other == "run" else "a study's table and cases"
        raise ConfigError(f"{where}: {folder} holds {what} ({OWNER_FILES[other]}); a {owner} "
                          f"of the same name would {'replace' if owner == 'run' else 'mix into'}"
                          f" it; rename the {owner} or move that folder")


def planned_files(spec) -> list[tuple[str, tuple]]:
    """(file or folder relative to the run's folder, YAML path that asks for it) of every
    output a run of ``spec`` (WorkflowSpec) writes, in writing order."""
    out: list[tuple[str, tuple]] = [("manifest.json", ())]
    ex = spec.outputs.exports
    for i, a in enumerate(spec.analyses):
        cases = [(slug(c.label), ("analyses", i, "cases", k, "label"))
                 for k, c in enumerate(a.cases)] or [("", ("analyses", i, "name"))]
        for s, where in cases:
            stem = a.name + (f"_{s}" if s else "")
            if ex.csv:
                if a.type == "linearised":
                    out.append((f"{stem}_modes.csv", where))
                out.append((f"{stem}.csv", where))
            if ex.npz:
                out.append((f"{stem}.npz", where))
            if ex.vtu:
                out.append((f"vtk/{stem}", where))
    o = spec.outputs
    for kind, ext in (("plots", "png"), ("renders", "png")):
        out += [(f"{x.name}.{ext}", ("outputs", kind, i, "name"))
                for i, x in enumerate(getattr(o, kind))]
    out += [(f"{x.name}.{x.format}", ("outputs", "animations", i, "name"))
            for i, x in enumerate(o.animations)]
    for i, c in enumerate(o.convergence):
        out += [(f"{c.name}.csv", ("outputs", "convergence", i, "name")),
                (f"{c.name}.png", ("outputs", "convergence", i, "name"))]
    return out


def file_collision(spec) -> tuple[str, tuple, tuple] | None:
    """(file, first YAML path, second YAML path) of the first two outputs that would write
    the same file (compared case-insensitively: not every file system tells them apart),
    or None."""
    seen: dict[str, tuple] = {}
    for name, where in planned_files(spec):
        key = name.lower()
        if key in seen:
            return name, seen[key], where
        seen[key] = where
    return None
