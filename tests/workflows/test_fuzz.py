"""The fuzzer (tests/workflows/fuzz.py) over the shipped workflows and link specs and two
rigid machines that are also built: every mutant is either accepted (when it may be valid)
or refused with one clear line; never a traceback, never a hang, never an invalid value
accepted. A few hundred mutants in the default run; more under ``-m slow``."""

from __future__ import annotations

import shutil
from pathlib import Path

import fuzz
import pytest
from test_workflow_run import FOURBAR
from test_workflow_trust import FREE

ROOT = Path(__file__).resolve().parents[2]


def _bases(tmp_path: Path) -> tuple[list, Path]:
    """(bases, folder for the mutants): the shipped files are copied so that a mutant of a
    workflow finds the link specs its relative paths name."""
    for sub in ("workflows", "meshes"):
        shutil.copytree(ROOT / sub, tmp_path / sub)
    bases = [("fourbar", FOURBAR, "workflow", True), ("free", FREE, "workflow", True)]
    for p in sorted((ROOT / "workflows").glob("*.yaml")):
        bases.append((p.stem, p.read_text(), "workflow", False))
    for p in sorted((ROOT / "meshes").glob("*.yaml")):
        bases.append((p.stem, p.read_text(), "link", False))
    return bases, tmp_path


def _run(tmp_path, n, seed):
    bases, root = _bases(tmp_path)
    out, left = {}, n
    for kind in ("workflow", "link"):
        folder = root / ("workflows" if kind == "workflow" else "meshes") / "fuzz"
        some = [b for b in bases if b[2] == kind]
        k = n * len(some) // len(bases) if kind == "workflow" else left  # n in all
        left -= k
        res = fuzz.run(some, k, seed, folder, tmp_path / "links")
        for key, v in res.items():
            out.setdefault(key, []).extend(v)
    print(fuzz.summary(out))
    bad = {k: v for k, v in out.items() if k not in ("ok", "clear")}
    assert not bad, "\n".join(f"{k}: {x}" for k, v in bad.items() for x in v[:5])
    return out


@pytest.mark.slow  # budget of the default run: .ci/run's slow run has it
def test_fuzz_workflows_and_link_specs(tmp_path):
    out = _run(tmp_path, 300, seed=1)
    assert len(out.get("clear", [])) > 100  # most mutants are invalid, and refused


@pytest.mark.slow
def test_fuzz_many(tmp_path):
    """2000 mutants (issue 26), the build's guards among the operators: inertias no motion
    can have, driver tables that are devices or folders, zero frame axes."""
    out = _run(tmp_path, 2000, seed=2)
    assert sum(len(v) for v in out.values()) >= 2000
