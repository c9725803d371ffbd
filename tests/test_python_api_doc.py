"""docs/python_api.md runs as written: every example prints what the page shows."""

from __future__ import annotations

import doctest
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = [pytest.mark.gmsh, pytest.mark.render]


@pytest.mark.slow  # budget of the default run: .ci/run's slow run has it
def test_python_api_page_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    result = doctest.testfile(
        str(ROOT / "docs" / "python_api.md"), module_relative=False,
        globs={"CACHE": tmp_path / "links", "OUT": tmp_path},
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 20
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed"
    assert os.path.exists(tmp_path / "swing.png")
