"""Read a workflow file: YAML with line numbers -> overrides -> schema -> reference checks.

:class:`Workflow` keeps the validated spec with where every value came from,
so later stages (building the machine, running analyses) can still report
``file:line: yaml.path: what was expected``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from pipeline.core.errors import ConfigError
from pipeline.core.hashing import content_hash
from pipeline.workflow.names import file_collision, run_name
from pipeline.workflow.overrides import apply_overrides, parse_assignment
from pipeline.workflow.schema import WorkflowSpec
from pipeline.workflow.yaml_io import PathKey, _fmt, config_error, load_yaml


@dataclass(frozen=True)
class Workflow:
    """A validated workflow.

    Attributes
    ----------
    spec : WorkflowSpec.  path : the YAML file.  data : raw data after overrides.
    lines : YAML path -> line in the file.  overrides : (path, value) applied (quick first).
    quick : whether the file's ``quick:`` overrides were applied.
    case : label of the analysis case this copy stands for ("" for the base workflow).
    """

    spec: WorkflowSpec
    path: Path
    data: Any
    lines: dict = field(repr=False)
    overrides: tuple = ()
    quick: bool = False
    case: str = ""

    @property
    def name(self) -> str:
        return self.spec.name or self.path.stem

    @property
    def base_dir(self) -> Path:
        return self.path.parent

    def where(self, *path: str | int) -> str:
        """``file:line: yaml.path`` of ``path`` (the nearest enclosing line if overridden)."""
        key: PathKey = tuple(path)
        while key and key not in self.lines:
            key = key[:-1]
        line = self.lines.get(key, 1)
        case = f" (case {self.case!r})" if self.case else ""
        return f"{self.path}:{line}: {_fmt(tuple(path))}{case}"

    def error(self, *path: str | int, msg: str) -> ConfigError:
        return ConfigError(f"{self.where(*path)}: {msg}")

    def input_hash(self) -> str:
        """Hash of the file text and the overrides (what the results depend on, besides
        the link specs, whose own hashes key their cached reductions)."""
        over = json.loads(json.dumps([[p, v] for p, v in self.overrides], default=str))
        return content_hash({"overrides": over}, (self.path,))

    def for_case(self, case_set: dict[str, Any], label: str) -> Workflow:
        """This workflow with a case's overrides applied (validated again)."""
        where = f"{self.path}: case {label!r}"
        data = apply_overrides(self.data, case_set, where)
        spec = _validate(data, self.path, self.lines)
        return Workflow(spec, self.path, data, self.lines,
                        self.overrides + tuple(case_set.items()), self.quick, label)


def _validate(data: Any, path: Path, lines: dict) -> WorkflowSpec:
    try:
        spec = WorkflowSpec.model_validate(data)
    except ValidationError as exc:
        raise config_error(exc, path, data, lines) from None
    return spec


def load_workflow(path: str | Path, sets: list[str] | tuple = (), quick: bool = False) -> Workflow:
    """Read, override and validate a workflow YAML.

    Parameters
    ----------
    path : workflow file.
    sets : ``"path=value"`` overrides (``--set``), applied after ``quick:``.
    quick : apply the file's ``quick:`` overrides (coarse meshes, short runs).

    Raises
    ------
    ConfigError
        File, YAML, schema or cross-reference errors, each naming file:line: yaml.path.
    """
    path = Path(path)
    data, lines = load_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}:1: expected a mapping at the top level")
    overrides: list[tuple[str, Any]] = []
    if quick:
        q = data.get("quick") or {}
        if not isinstance(q, dict):
            raise ConfigError(f"{path}:{lines.get(('quick',), 1)}: quick: expected a mapping "
                              "of path: value")
        overrides += list(q.items())
        data = apply_overrides(data, q, f"{path}: quick")
    assigned = [parse_assignment(s) for s in sets]
    overrides += assigned
    data = apply_overrides(data, assigned, f"{path}: --set")
    wf = Workflow(_validate(data, path, lines), path, data, lines, tuple(overrides), quick)
    check_references(wf)
    return wf


def check_references(wf: Workflow) -> None:
    """Names that must exist: one ground, joint frames' links, analyses named by outputs,
    unique names. Coordinates are checked when the machine is built."""
    spec = wf.spec
    run_name(spec.name, wf.path, wf.where("name"))
    grounds = [k for k, v in spec.links.items() if v.type == "ground"]
    if len(grounds) != 1:
        raise wf.error("links", msg=f"expected exactly one link with type: ground, got {grounds}")
    for i, j in enumerate(spec.joints):
        for side in ("parent", "child"):
            link = getattr(j, side).split(".", 1)[0]
            if link not in spec.links:
                raise wf.error("joints", i, side, msg=f"link {link!r} is not one of "
                                                      f"{sorted(spec.links)}")
    for key, items in (("joints", spec.joints), ("forces", spec.forces),
                       ("analyses", spec.analyses)):
        names = [x.name for x in items]
        for i, n in enumerate(names):
            if names.index(n) != i:
                raise wf.error(key, i, "name", msg=f"duplicate name {n!r}")
    known = [a.name for a in spec.analyses]
    for kind in ("plots", "renders", "animations", "convergence"):
        for i, o in enumerate(getattr(spec.outputs, kind)):
            if o.analysis not in known:
                raise wf.error("outputs", kind, i, "analysis",
                               msg=f"expected one of the analyses {known}, got {o.analysis!r}")
    names = [o.name for k in ("plots", "renders", "animations", "convergence")
             for o in getattr(spec.outputs, k)]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise wf.error("outputs", msg=f"duplicate output names {dup} (they name files)")
    for kind, key in (("plots", "cases"), ("renders", "case"), ("animations", "case")):
        for i, o in enumerate(getattr(spec.outputs, kind)):
            asked = getattr(o, key)
            asked = [] if asked is None else [asked] if isinstance(asked, str) else asked
            labels = [c.label for c in spec.analysis(o.analysis).cases]
            bad = [c for c in asked if c not in labels]
            if bad:
                raise wf.error("outputs", kind, i, key,
                               msg=f"expected case labels of analysis {o.analysis!r} among "
                                   f"{labels}, got {bad}")
    for kind in ("renders", "animations"):
        for i, o in enumerate(getattr(spec.outputs, kind)):
            if o.links is None:
                continue
            bad = [n for n in o.links if n not in spec.links]
            if bad:
                raise wf.error("outputs", kind, i, "links",
                               msg=f"expected links among {sorted(spec.links)}, got {bad}")
            # a ground without a shape draws nothing (its frames are joints of other links)
            if all(spec.links[n].type == "ground" and spec.links[n].shape is None
                   for n in o.links):
                raise wf.error("outputs", kind, i, "links",
                               msg=f"expected at least one link that is drawn (a ground "
                                   f"without a shape is not), got {o.links}")
    for a in spec.analyses:  # each case's overrides give a valid workflow (the schema)
        for c in a.cases:
            wf.for_case(c.set, c.label)
    clash = file_collision(spec)
    if clash:
        file, first, second = clash
        raise wf.error(*second, msg=f"would write {file!r}, as {_fmt(first)} does (file names "
                                    "keep letters, digits, '_', '-' and '.'; rename one)")
