"""The cases of a study: override sets (``--set`` paths) with labels and input hashes."""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.core.hashing import content_hash
from pipeline.study.spec import mode_label
from pipeline.workflow.link_build import REDUCTION_REVISION, versions

#: what a truncation case records besides the compared series (2: the world positions of
#: the truncated link's frames and the machine's lowest frequencies); a change reruns cases
EVIDENCE_REVISION = 2


@dataclass(frozen=True)
class Case:
    """One run of the base workflow.

    Attributes
    ----------
    label : unique, readable ("boom=2 modes", "forces.load.force=[0, -1000, 0]").
    overrides : path -> value, applied to the base workflow as with ``--set``.
    kind : "truncation" or "design".
    link, modes : the truncation case's link and kept modes as text ("2",
        "effective_mass=0.9"; else ""), order : its place in the study's list (-1).
    input_hash : what the case's results depend on (base file, overrides, analyses,
        versions): a case already in the table with the same hash is not run again.
    """

    label: str
    overrides: dict[str, Any]
    kind: str
    link: str = ""
    modes: str = ""
    order: int = -1
    input_hash: str = field(default="", compare=False)


def study_cases(spec, base_path: Path, flexible_links: list[str],
                inputs: list[Path] = ()) -> list[Case]:
    """Every case of ``spec`` (truncation first, then design: grid, cases, random), each
    hashed with the base workflow's text and the ``inputs`` it reads (link specs,
    tables)."""
    out: list[Case] = []
    t = spec.truncation
    if t is not None:
        for link in t.links or flexible_links:
            for i, k in enumerate(t.modes):
                label = mode_label(k)
                out.append(Case(f"{link}: {label} modes" if isinstance(k, int) else
                                f"{link}: {label}", {f"links.{link}.modes": k},
                                "truncation", link, label, i))
    d = spec.design
    if d is not None:
        if d.grid:
            keys = list(d.grid)
            for values in itertools.product(*(d.grid[k] for k in keys)):
                out.append(Case(_label(dict(zip(keys, values))), dict(zip(keys, values)),
                                "design"))
        out += [Case(_label(c), dict(c), "design") for c in d.cases]
        if d.random is not None:
            rng = np.random.default_rng(d.random.seed)
            for _ in range(d.random.n):
                c = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in d.random.ranges.items()}
                out.append(Case(_label(c), c, "design"))
    seen: dict[str, int] = {}
    unique = []
    for c in out:  # the same overrides twice (a grid and a list) run once
        key = json.dumps(c.overrides, sort_keys=True, default=str)
        if key not in seen:
            seen[key] = len(unique)
            unique.append(c)
    common = {"workflow": content_hash({}, (Path(base_path), *inputs)),
              "quick": spec.quick, "set": spec.set, "analyses": spec.analyses,
              "versions": versions(),
              "reduction": REDUCTION_REVISION,
              "evidence": EVIDENCE_REVISION,
              "compare": spec.truncation.series if spec.truncation else [],
              "outputs": [o.model_dump() for o in spec.outputs]}
    return [replace(c, input_hash=content_hash({**common, "overrides": c.overrides}))
            for c in unique]


def _label(overrides: dict[str, Any]) -> str:
    def short(v):
        return f"{v:.6g}" if isinstance(v, float) else json.dumps(v, default=str)

    return ", ".join(f"{k}={short(v)}" for k, v in overrides.items()) or "base"
