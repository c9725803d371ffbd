"""Shared fixture: each shipped workflow run once per test session in --quick mode.

``quick_run("front_loader")`` returns the RunResult of
``pipeline run workflows/front_loader.yaml --quick`` (all outputs written into a
session temporary folder, reduced links cached there), so the file checks and the
physics checks of a machine share one run.
"""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
WORKFLOWS = ROOT / "workflows"


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory):
    from pipeline.workflow import run_workflow

    root = tmp_path_factory.mktemp("quick_runs")
    done = {}

    def run(name: str, sets: tuple[str, ...] = ()):
        key = (name, tuple(sets))
        if key not in done:
            done[key] = run_workflow(WORKFLOWS / f"{name}.yaml", out_root=root / str(len(done)),
                                     quick=True, sets=list(sets), cache_dir=root / "links")
        return done[key]

    return run
