"""The notebook in docs/ (the main job end to end from pipeline.api) executed in a real
Jupyter kernel (nbclient, ipykernel): it runs without an error, shows its Figure inline
(the post functions make figures outside pyplot and change no process-wide state), and
finds the run ok."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

nbclient = pytest.importorskip("nbclient")
nbformat = pytest.importorskip("nbformat")
pytest.importorskip("ipykernel")
pytestmark = pytest.mark.gmsh

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK = ROOT / "docs" / "notebooks" / "main_job.ipynb"


@pytest.mark.slow  # a Jupyter kernel running the main job quick (10 s)
def test_the_main_job_notebook_runs_and_shows_its_figures_inline(tmp_path, monkeypatch):
    monkeypatch.setenv("PIPELINE_NOTEBOOK_QUICK", "1")
    monkeypatch.setenv("PIPELINE_NOTEBOOK_OUT", str(tmp_path / "out"))
    monkeypatch.delenv("MPLBACKEND", raising=False)  # a notebook's own: inline
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbclient.NotebookClient(nb, timeout=900, kernel_name="python3",
                            resources={"metadata": {"path": str(NOTEBOOK.parent)}}).execute()
    code = [c for c in nb.cells if c.cell_type == "code"]
    outputs = [o for c in code for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"]
    text = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert re.search(r"^ok -> ", text, re.MULTILINE) and re.search(r"^swing\s+flexible\s+ok", text, re.MULTILINE)
    figure = next(c for c in code if "panels_figure" in c.source)
    assert any("image/png" in o.get("data", {}) for o in figure.outputs), figure.outputs
    gaps = next(c for c in code if c.source.strip().endswith("gap")).outputs[0]
    values = ast.literal_eval(gaps["data"]["text/plain"])
    assert set(values) == {"J1.theta", "J2.theta"} and all(v > 0 for v in values.values())
    assert (tmp_path / "out" / "double_pendulum" / "report.html").is_file()
