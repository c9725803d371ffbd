"""Drawing a plot changes no process-wide state (issue 29 item 5): no matplotlib backend
switch, no figure left in pyplot, so a notebook's inline figures go on working."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_no_backend_switch_and_no_open_figures(tmp_path):
    """In a fresh interpreter whose backend is chosen (as a notebook's inline one is), the
    package's plots leave it and pyplot's figure list as they were."""
    code = f"""
import matplotlib
matplotlib.use("svg")
import matplotlib.pyplot as plt
import numpy as np
from pipeline.post.plots import Curve, Panel, plot_panels
from pipeline.post.study_plot import plot_convergence, plot_outputs
t = np.linspace(0, 1, 5)
plot_panels({str(tmp_path / 'a.png')!r}, [Panel("p", "t, s", "x, m", [Curve("x", t, t)])])
plot_convergence({str(tmp_path / 'b.png')!r}, ["fine", "coarse"], {{"q": [0.0, 0.1]}}, reference="fine")
plot_outputs({str(tmp_path / 'c.png')!r}, [{{"set:k": "1", "out:y": 2.0}}], "y", "k")
print(matplotlib.get_backend(), len(plt.get_fignums()))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=False, env={"PATH": "", "PYTHONPATH": str(ROOT),
                                           "MPLBACKEND": "svg"})
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["svg", "0"]
    for name in "abc":
        assert (tmp_path / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_package_never_sets_the_backend():
    hits = [str(p.relative_to(ROOT)) for p in (ROOT / "pipeline").rglob("*.py")
            if "matplotlib.use(" in p.read_text()]
    assert hits == []
