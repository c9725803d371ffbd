"""``pipeline preview WORKFLOW``: the machine built and pictured before any analysis, its
frames drawn (issue 29, item 3)."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflows"))
from test_hydraulic_workflow import LIFT

pytestmark = [pytest.mark.render]


def _red(path):
    from PIL import Image

    img = np.asarray(Image.open(path).convert("RGB")).astype(float)
    return float((np.abs(img - (255.0, 0.0, 0.0)).max(axis=2) < 40).mean())


def test_preview_builds_reports_and_draws_the_frames(tmp_path, capsys, monkeypatch):
    from pipeline.cli import main
    from pipeline.post.scene import Style, render_machine
    from pipeline.workflow import build_machine, load_workflow
    from pipeline.workflow.outputs import machine_shapes

    monkeypatch.chdir(tmp_path)
    wf = tmp_path / "lift.yaml"  # a marker off the mass: its triad in the open
    wf.write_text(LIFT.replace("frames: {eye: {origin: [0, 0, 0]}}",
                               "frames: {eye: {origin: [0, 0, 0]}, tip: {origin: [0.3, 0, 0]}}"))
    assert main(["preview", str(wf)]) == 0
    out = capsys.readouterr().out
    assert "'lift' as built: 1 coordinates" in out and "DOF 1 = 1 coordinates" in out, out
    path = tmp_path / "output" / "previews" / "lift.png"
    assert path.stat().st_size > 0 and not (tmp_path / "output" / "lift").exists()
    # the frames are what the preview adds to a still: without them far less red
    m = build_machine(load_workflow(wf), tmp_path / "links")
    plain = render_machine(tmp_path / "plain.png", m.mechanism, machine_shapes(m), m.q0,
                           style=Style(up=(0, 0, 1))).path
    assert _red(path) > 2 * _red(plain) and _red(path) > 1e-4  # 2.6x measured


def test_a_bad_camera_is_one_line(tmp_path, capsys):
    from pipeline.cli import main

    wf = tmp_path / "lift.yaml"
    wf.write_text(LIFT)
    assert main(["preview", str(wf), "--camera", "sideways", "--out",
                 str(tmp_path / "p.png")]) != 0
    err = capsys.readouterr().err
    assert "camera" in err and "Traceback" not in err and not (tmp_path / "p.png").exists()
