"""Earlier runs kept beside the latest (issue 29 item 4): each run's folder moves whole to
``<name>.history/<created>/`` when the next run replaces it, within the workflow's budget
of runs and megabytes."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_workflow_run import FOURBAR

from pipeline.workflow import run_workflow
from pipeline.workflow.history import history_dir, kept_runs


def _run(tmp_path: Path, rate: float, history: str = "") -> Path:
    p = tmp_path / "fourbar.yaml"
    text = FOURBAR.replace("rate: 6.283185307179586", f"rate: {rate}")
    p.write_text(text + history)
    return run_workflow(p, out_root=tmp_path / "out", outputs=False).out_dir


def _hash(folder: Path) -> str:
    return json.loads((folder / "manifest.json").read_text())["input_hash"]


def test_each_run_moves_the_one_it_replaces_into_the_history(tmp_path):
    hashes = []
    for rate in (1.0, 2.0, 3.0, 4.0):
        latest = _run(tmp_path, rate, "  history: {runs: 2}\n")
        hashes.append(_hash(latest))
    assert len(set(hashes)) == 4
    kept = kept_runs(latest)
    # the two runs before the latest, newest first, whole: their own manifests
    assert [_hash(p) for p in kept] == hashes[2::-1][:2]
    assert history_dir(latest) == tmp_path / "out" / "fourbar.history"
    assert sorted(x.name for x in (tmp_path / "out").iterdir()) == ["fourbar",
                                                                      "fourbar.history"]
    assert all((p / "manifest.json").is_file() for p in kept)


def test_no_history_or_a_size_budget_keeps_fewer(tmp_path):
    _run(tmp_path, 1.0, "  history: {runs: 0}\n")
    latest = _run(tmp_path, 2.0, "  history: {runs: 0}\n")
    assert kept_runs(latest) == [] and not history_dir(latest).exists()
    # a budget smaller than one run keeps none of them
    third = _hash(_run(tmp_path, 3.0, "  history: {runs: 5, mb: 0.000001}\n"))
    assert kept_runs(latest) == []
    latest = _run(tmp_path, 4.0)  # the defaults: 5 runs, 500 MB
    assert [_hash(p) for p in kept_runs(latest)] == [third]


def test_a_bad_history_setting_is_refused_at_its_line(tmp_path):
    from pipeline.core.errors import ConfigError

    with pytest.raises(ConfigError, match=r"fourbar\.yaml:\d+: outputs\.history\.runs: "):
        _run(tmp_path, 1.0, "  history: {runs: -1}\n")
