"""The run report (pipeline.post.report): one self-contained HTML page per run, opened in
a real headless browser (Debian's chromium; these tests skip cleanly without it): it
loads without errors, every figure decodes, and its screenshot matches a stored reference
within a tolerance."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pipeline.post.report import column_peaks, report_html, write_report

HERE = Path(__file__).resolve().parent
REFERENCE = HERE / "reference" / "report_screenshot.png"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed "
                                    "(apt install chromium)")
#: the screenshot's size, px
WIDTH, HEIGHT = 1100, 1500

MANIFEST = {
    "workflow": "workflows/crank.yaml", "name": "crank", "status": "suspect",
    "input_hash": "0123456789abcdef" * 4, "quick": False, "overrides": [["t_end", 2.0]],
    "versions": {"pipeline": "0.1.0"}, "coordinates": ["JA.theta", "slide.d", "arm.eta1"],
    "coordinate_units": ["rad", "m", "-"],
    "model": {"loops": 1, "dof": 2, "redundant": ["L1 (cut 'JC'): rotation x"],
              "warnings": ["arm: 1 mode kept; the basis misses the axial load path"],
              "notes": []},
    "links": {"arm": {"artifact": "a1b2c3d4e5f6", "cache": "hit", "modes": [0],
                      "frequencies_hz": [12.5]}},
    "analyses": {"turn": [{"case": "", "type": "dynamic", "success": True,
                           "verdict": "suspect", "expected": "ok", "message": "finished",
                           "warnings": ["estimated error 3e-4 above the tolerance 1e-4"],
                           "outputs": 5, "seconds": 0.25}]},
    "timings_s": {"total": 1.5}, "files": ["turn.csv", "turn.png", "rocker.png"],
    "created": "2026-11-27T12:00:00Z", "skipped_outputs": [],
}


def _synthetic_run(folder: Path) -> Path:
    """A run folder with a fixed manifest, a result table and two plots (drawn the same on
    every machine with the same matplotlib)."""
    from pipeline.post.plots import new_figure, save_figure

    folder.mkdir(parents=True, exist_ok=True)
    (folder / "manifest.json").write_text(json.dumps(MANIFEST))
    t = np.linspace(0.0, 1.0, 5)
    rows = ["time_s,JA.theta,slide.d,arm.eta1,tip.y_m,energy:kinetic_J"]
    rows += [f"{x},{np.sin(3 * x)},{-0.5 * x},{1e-4 * x},{0.2 - x},{4 * x * x}" for x in t]
    (folder / "turn.csv").write_text("\n".join(rows) + "\n")
    for name, f in (("turn.png", np.sin), ("rocker.png", np.cos)):
        fig = new_figure((5.0, 3.0), dpi=80)
        ax = fig.add_subplot()
        x = np.linspace(0, 6, 200)
        ax.plot(x, f(x), lw=2)
        ax.set_title(name)
        save_figure(fig, folder / name)
    return folder


def _chromium(url: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
                           "--hide-scrollbars", "--force-device-scale-factor=1", *args, url],
                          check=False, capture_output=True, text=True, timeout=180)


def _body(dom: str) -> dict:
    tag = re.search(r"<body([^>]*)>", dom).group(1)
    return dict(re.findall(r'data-(\w+)="([^"]*)"', tag))


def test_the_report_holds_the_run_and_nothing_from_elsewhere(tmp_path):
    folder = _synthetic_run(tmp_path / "crank")
    page = write_report(folder).read_text()
    assert page.count("data:image/png;base64,") == 2  # both plots, embedded
    # no resource is fetched: every src is embedded; links point into the folder
    assert not re.search(r'src="(?!data:)', page)
    assert not re.search(r'href="(https?:|/)', page)
    for text in ("suspect", "estimated error 3e-4", "2 degrees of freedom",
                 "L1 (cut &#x27;JC&#x27;): rotation x", "the basis misses the axial load",
                 "12.5", 'href="turn.csv"', "t_end=2.0"):
        assert text in page, text
    assert report_html(folder) == page


def test_peak_values_carry_their_units_and_times(tmp_path):
    folder = _synthetic_run(tmp_path / "crank")
    peaks = {c: (x, t) for c, x, t in column_peaks(folder / "turn.csv")}
    assert peaks["slide.d"] == (0.5, 1.0) and peaks["energy:kinetic_J"] == (4.0, 1.0)
    assert peaks["JA.theta"] == (pytest.approx(np.sin(1.5), abs=1e-10), 0.5)
    page = report_html(folder)
    row = re.search(r"<tr><td>slide\.d</td><td class=\"num\">([^<]*)</td><td>([^<]*)</td>"
                    r"<td class=\"num\">([^<]*)</td></tr>", page)
    assert row and row.groups() == ("0.5", "m", "1")
    assert re.search(r"<td>energy:kinetic</td><td class=\"num\">4</td><td>J</td>", page)
    assert re.search(r"<td>tip\.y</td><td class=\"num\">0\.8</td><td>m</td>", page)


def test_a_folder_without_a_manifest_is_named():
    with pytest.raises(FileNotFoundError, match="not a finished run"):
        report_html(Path("/nonexistent/run"))


@needs_chromium
def test_the_report_loads_in_chromium_without_errors_and_its_figures_decode(tmp_path):
    folder = _synthetic_run(tmp_path / "crank")
    out = _chromium((write_report(folder)).as_uri(), "--dump-dom")
    assert out.returncode == 0, out.stderr[-2000:]
    assert _body(out.stdout) == {"errors": "0", "figures": "2"}
    # a broken figure is seen (the check can fail)
    page = report_html(folder).replace("base64,iVBOR", "base64,AAAA", 1)
    (folder / "broken.html").write_text(page)
    out = _chromium((folder / "broken.html").as_uri(), "--dump-dom")
    assert _body(out.stdout) == {"errors": "1", "figures": "1"}


def _gray_blocks(path: Path, block: int = 10) -> np.ndarray:
    import imageio.v3 as iio

    img = iio.imread(path).astype(float) / 255.0
    g = img[..., :3].mean(axis=2)[:HEIGHT, :WIDTH]
    h, w = (g.shape[0] // block) * block, (g.shape[1] // block) * block
    return g[:h, :w].reshape(h // block, block, w // block, block).mean(axis=(1, 3))


@needs_chromium
def test_the_reports_screenshot_matches_the_reference(tmp_path):
    """The page as a browser draws it (layout, tables, the plots) against a stored
    screenshot: 10 px blocks, mean difference below 1 % of full scale, none above 25 %.
    Regenerate after an intended change: python tests/post/test_report.py."""
    folder = _synthetic_run(tmp_path / "crank")
    shot = tmp_path / "shot.png"
    out = _chromium(write_report(folder).as_uri(), f"--window-size={WIDTH},{HEIGHT}",
                    f"--screenshot={shot}")
    assert out.returncode == 0 and shot.is_file(), out.stderr[-2000:]
    a, b = _gray_blocks(shot), _gray_blocks(REFERENCE)
    assert a.shape == b.shape
    diff = np.abs(a - b)
    assert diff.mean() < 0.01 and diff.max() < 0.25, (diff.mean(), diff.max())
    # and the plots are on it: their blocks differ from a page without figures
    bare = tmp_path / "bare"
    _synthetic_run(bare)
    man = json.loads((bare / "manifest.json").read_text())
    man["files"] = ["turn.csv"]
    (bare / "manifest.json").write_text(json.dumps(man))
    shot2 = tmp_path / "bare.png"
    _chromium(write_report(bare).as_uri(), f"--window-size={WIDTH},{HEIGHT}",
              f"--screenshot={shot2}")
    assert np.abs(_gray_blocks(shot2) - b).max() > 0.25


if __name__ == "__main__":  # regenerate the reference screenshot
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        run = _synthetic_run(Path(d) / "crank")
        _chromium(write_report(run).as_uri(), f"--window-size={WIDTH},{HEIGHT}",
                  f"--screenshot={REFERENCE}")
    print(f"wrote {REFERENCE}", file=sys.stderr)
