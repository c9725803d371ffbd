"""``pipeline render RUN_FOLDER``: a run's pictures drawn again from its saved results with
other settings, no analysis run (issue 29, item 3)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_hydraulic_workflow import LIFT

from pipeline.core.errors import ConfigError
from pipeline.workflow import run_workflow

pytestmark = [pytest.mark.render]

DRAWN = LIFT.replace(
    "  exports: {csv: true, npz: true}\n",
    "  renders:\n    - {name: still, analysis: raise}\n  exports: {csv: true, npz: true}\n")


def _run(tmp_path, text=DRAWN):
    wf = tmp_path / "lift.yaml"
    wf.write_text(text)
    return run_workflow(wf, out_root=tmp_path / "out", cache_dir=tmp_path / "links")


def test_the_pictures_are_drawn_again_from_the_saved_results_alone(tmp_path, monkeypatch,
                                                                    capsys):
    from PIL import Image

    import pipeline.solver
    from pipeline.cli import main
    from pipeline.workflow import analyses

    res = _run(tmp_path)
    folder = res.out_dir
    plot = np.asarray(Image.open(folder / "pressures.png"))
    (folder / "still.png").unlink()
    report = (folder / "report.html").stat().st_mtime_ns

    def no_analysis(*args, **kwargs):
        raise AssertionError("render ran an analysis")

    # every way into an analysis: the runner, the integrator, the statics
    monkeypatch.setattr(analyses, "run_analysis", no_analysis)
    monkeypatch.setattr(analyses, "static_equilibrium", no_analysis)
    monkeypatch.setattr(pipeline.solver, "simulate", no_analysis)
    assert main(["render", str(folder), "--links", str(tmp_path / "links"),
                 "--set", "outputs.plots.pressures.title=Drawn again"]) == 0
    assert "drew 2 files again" in capsys.readouterr().out
    assert (folder / "still.png").stat().st_size > 0  # the missing still is back
    again = np.asarray(Image.open(folder / "pressures.png"))
    assert again.shape == plot.shape and np.abs(again.astype(int) - plot).max() > 0  # title
    assert (folder / "report.html").stat().st_mtime_ns > report
    man = json.loads((folder / "manifest.json").read_text())
    assert man["status"] == "ok"  # the run's record is the run's


def test_the_saved_results_read_back_as_the_run_s(tmp_path):
    from pipeline.workflow.rerender import read_result

    res = _run(tmp_path)
    r = res.result("raise", "")
    back = read_result(res.out_dir / "raise.npz", "raise", "dynamic", "",
                       {"lift.p_a": "Pa", "lift.p_b": "Pa"})
    for x in ("t", "q", "qd", "qdd"):
        np.testing.assert_array_equal(getattr(back, x), getattr(r, x))
    assert back.states["lift.p_a"][0] == "Pa"
    np.testing.assert_array_equal(back.states["lift.p_a"][1], r.states["lift.p_a"][1])
    assert (back.verdict, back.coordinates) == (r.verdict, r.coordinates)
    assert set(back.energies) == set(r.energies)


def test_render_changes_only_how_results_are_drawn(tmp_path):
    from pipeline.workflow.rerender import render_run

    folder = _run(tmp_path).out_dir
    with pytest.raises(ConfigError, match=r"--set analyses\.raise\.t_end=1: expected "
                                          r"outputs\.<\.\.\.>=value"):
        render_run(folder, ["analyses.raise.t_end=1"], tmp_path / "links")
    (folder / "raise.npz").unlink()
    with pytest.raises(ConfigError, match=r"raise\.npz is missing.*exports\.npz: true"):
        render_run(folder, (), tmp_path / "links")
    with pytest.raises(ConfigError, match="expected a run's folder holding manifest.json"):
        render_run(tmp_path, (), tmp_path / "links")


def test_a_render_title_names_the_magnification_it_is_drawn_at():
    """A title's ``{scale}`` is the magnification drawn, so a render at another scale
    (``--set outputs.renders.<name>.scale=20``) does not keep a stale "x5"; the title is
    plain text, never a format string."""
    from pipeline.workflow.outputs import _with_scale

    assert _with_scale("drawn x{scale}", 20.0) == "drawn x20"
    assert _with_scale("drawn x{scale}", 2.5e-3) == "drawn x0.0025"
    assert _with_scale("{0.__class__} {scale!r} {}", 3.0) == "{0.__class__} {scale!r} {}"
    assert _with_scale(None, 3.0) is None
