"""Running workflows: a closed loop written in YAML against the four-bar closed form,
partial results marked as such, parallel cases equal to sequential ones, atomic output
folders and the manifest's input hash."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pipeline.core.errors import ConfigError
from pipeline.workflow import load_workflow, run_workflow

# crank a = 1, coupler b = 3, rocker c = 2, ground d = 3.5: Grashof crank-rocker
FOURBAR = """\
name: fourbar
gravity: [0, -9.81, 0]
links:
  ground:
    type: ground
    frames:
      A: {origin: [0, 0, 0]}
      D: {origin: [3.5, 0, 0]}
  crank:
    type: rigid
    mass: 1.0
    com: [0.5, 0, 0]
    inertia: [0.001, 0.1, 0.1, 0, 0, 0]
    frames: {A: {origin: [0, 0, 0]}, B: {origin: [1.0, 0, 0]}}
  coupler:
    type: rigid
    mass: 3.0
    com: [1.5, 0, 0]
    inertia: [0.003, 2.3, 2.3, 0, 0, 0]
    frames: {B: {origin: [0, 0, 0]}, C: {origin: [3.0, 0, 0]}}
  rocker:
    type: rigid
    mass: 2.0
    com: [1.0, 0, 0]
    inertia: [0.002, 0.7, 0.7, 0, 0, 0]
    frames: {D: {origin: [0, 0, 0]}, C: {origin: [2.0, 0, 0]}}
joints:
  - {name: JA, type: revolute, parent: ground.A, child: crank.A, initial: [1.0]}
  - {name: JB, type: revolute, parent: crank.B, child: coupler.B, initial: [-0.6]}
  - {name: JD, type: revolute, parent: ground.D, child: rocker.D, initial: [1.9]}
  - {name: JC, type: revolute, parent: rocker.C, child: coupler.C, initial: [1.5]}
drivers:
  JA.theta: {type: ramp, t0: 0.0, rate: 6.283185307179586, v0: 1.0}
analyses:
  - name: turn
    type: kinematic
    t_end: 1.0
    outputs: 73
    markers: [coupler.C]
    cases:
      - {label: slow, set: {}}
      - {label: fast, set: {drivers.JA.theta.rate: 12.566370614359172}}
outputs:
  plots:
    - {name: rocker, analysis: turn, series: [q:JD.theta]}
"""


def _write(tmp_path, text=FOURBAR) -> Path:
    p = tmp_path / "fourbar.yaml"
    p.write_text(text)
    return p


def _rocker_closed_form(theta, a=1.0, b=3.0, c=2.0, d=3.5):
    """Rocker angle (open branch) from the crank angle: intersect the circle of radius b
    about B with the circle of radius c about D (independent of the 4x4 machinery)."""
    B = np.stack([a * np.cos(theta), a * np.sin(theta)], axis=1)
    D = np.array([d, 0.0])
    e = D - B
    L = np.linalg.norm(e, axis=1)
    u = e / L[:, None]
    x = (L ** 2 + c ** 2 - b ** 2) / (2 * L)  # distance from D back towards B
    h = np.sqrt(c ** 2 - x ** 2)
    n = np.stack([-u[:, 1], u[:, 0]], axis=1)
    C = D - x[:, None] * u + h[:, None] * n
    return np.arctan2(C[:, 1] - D[1], C[:, 0] - D[0]), C


def test_fourbar_from_yaml_matches_closed_form(tmp_path):
    res = run_workflow(_write(tmp_path), out_root=tmp_path / "out", outputs=False)
    for case in ("slow", "fast"):
        r = res.result("turn", case)
        assert r.success, r.message
        th = r.q[:, r.coordinates.index("JA.theta")]
        phi_ref, C_ref = _rocker_closed_form(th)
        phi = r.q[:, r.coordinates.index("JD.theta")]
        assert np.abs(np.angle(np.exp(1j * (phi - phi_ref)))).max() < 1e-9
    assert np.ptp(res.result("turn", "fast").q[:, 0]) == pytest.approx(4 * np.pi)


def test_unreachable_motion_is_partial_and_marked(tmp_path):
    # a 1.2 m rocker cannot follow the crank all round: the loop opens part way
    res = run_workflow(_write(tmp_path), out_root=tmp_path / "out",
                       sets=["links.rocker.frames.C.origin=[1.2, 0, 0]",
                             "links.ground.frames.D.origin=[2.5, 0, 0]",
                             "links.coupler.frames.C.origin=[2.2, 0, 0]",
                             "joints.JD.initial=[1.7]", "joints.JC.initial=[1.9]",
                             "outputs.plots=[]"])
    r = res.result("turn", "slow")
    assert not r.success and 1 < len(r.t) < 73
    man = json.loads((res.out_dir / "manifest.json").read_text())
    assert man["status"] == "partial"
    assert man["analyses"]["turn"][0]["success"] is False
    rows = (res.out_dir / "turn_slow.csv").read_text().splitlines()
    assert len(rows) == len(r.t) + 1  # header + the points reached


def test_parallel_cases_equal_sequential(tmp_path):
    seq = run_workflow(_write(tmp_path), out_root=tmp_path / "a", outputs=False)
    par = run_workflow(_write(tmp_path), out_root=tmp_path / "b", outputs=False, workers=2)
    for case in ("slow", "fast"):
        assert np.array_equal(seq.result("turn", case).q, par.result("turn", case).q)


def test_failed_run_keeps_previous_results_and_leaves_no_temporaries(tmp_path):
    p = _write(tmp_path)
    out = tmp_path / "out"
    first = run_workflow(p, out_root=out, outputs=False)
    before = (first.out_dir / "manifest.json").read_text()
    # fails after the analyses ran: a render of a case that does not exist
    bad = FOURBAR + "  renders:\n    - {name: still, analysis: turn, case: nope}\n"
    with pytest.raises(ConfigError, match=r"outputs\.renders\[0\]\.case"):
        run_workflow(_write(tmp_path, bad), out_root=out)
    assert (first.out_dir / "manifest.json").read_text() == before
    assert sorted(x.name for x in out.iterdir()) == ["fourbar"]


def test_input_hash_follows_the_inputs(tmp_path):
    p = _write(tmp_path)
    h0 = load_workflow(p).input_hash()
    assert load_workflow(p).input_hash() == h0
    assert load_workflow(p, sets=["analyses.turn.t_end=2"]).input_hash() != h0
    p.write_text(FOURBAR.replace("mass: 3.0", "mass: 3.1"))
    assert load_workflow(p).input_hash() != h0


MESHED = """\
name: meshed
gravity: [0, -9.81, 0]
links:
  ground:
    type: ground
    frames: {O: {origin: [0, 0, 0]}}
  bar:
    type: rigid
    spec:
      name: small_bar
      geometry:
        type: solid
        recipe: bar
        params: {L: 0.3, b: 0.02, h: 0.01}
        mesh_size: 0.01
        order: 2
      material: {E: 2.1e11, nu: 0.3, rho: 7850}
      interfaces:
        - {name: root, selector: {type: group, name: end_x0}, origin: [0, 0, 0],
           z_axis: [0, 0, 1], x_axis: [1, 0, 0]}
      reference: root
      modes: {count: 2}
    spec_overrides: {geometry.mesh_size: 0.02}
    frames:
      pin: {on: root, origin: [0, 0, 0.005]}
joints:
  - {name: J1, type: revolute, parent: ground.O, child: bar.root}
analyses:
  - {name: rest, type: static, initial: {coordinates: {J1.theta: -1.4}}}
"""


@pytest.mark.gmsh
def test_rigid_link_from_a_mesh_has_the_solid_s_mass_properties(tmp_path):
    p = tmp_path / "meshed.yaml"
    p.write_text(MESHED)
    res = run_workflow(p, out_root=tmp_path / "out", cache_dir=tmp_path / "links",
                       outputs=False)
    m = res.machine
    assert m.mechanism.n == 1  # rigid: no modal coordinates although the spec computes 2
    C = np.asarray(m.system.bodies["bar"].C)
    L, b, h, rho = 0.3, 0.02, 0.01, 7850.0
    mass = rho * L * b * h
    assert C[3, 3] == pytest.approx(mass, rel=1e-10)
    assert C[0, 3] == pytest.approx(mass * L / 2, rel=1e-10)
    assert C[0, 0] == pytest.approx(mass * L ** 2 / 3, rel=1e-10)  # int rho x^2 dV
    assert "pin" in [f.name for f in m.mechanism.links[m.mechanism.link_index("bar")].frames]
    r = res.result("rest")
    assert r.success and r.q[0, 0] == pytest.approx(-np.pi / 2, abs=1e-9)  # hangs down


def test_a_run_writes_its_report_and_it_loads_in_a_browser(tmp_path):
    """The report (pipeline.post.report) of a real run: in its folder and manifest, with the
    model's mobility (a planar four-bar on spatial revolutes: 4 coordinates, rank 3, three
    redundant rows); it opens in headless chromium with no error and every figure decoded,
    and `pipeline report` makes the same page again from the folder."""
    import re
    import shutil
    import subprocess

    from pipeline import cli

    res = run_workflow(_write(tmp_path), out_root=tmp_path / "out",
                       cache_dir=tmp_path / "links")
    man = res.manifest
    assert "report.html" in man["files"] and (res.out_dir / "report.html").is_file()
    assert man["coordinate_units"] == ["rad"] * 4
    assert man["model"]["loops"] == 1 and man["model"]["dof"] == 1
    assert len(man["model"]["redundant"]) == 3
    page = (res.out_dir / "report.html").read_text()
    figures = [f for f in man["files"] if f.endswith((".png", ".gif"))]
    assert figures and page.count("<figure><img") == len(figures)
    assert cli.main(["report", str(res.out_dir)]) == 0
    assert (res.out_dir / "report.html").read_text() == page
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("chromium is not installed (apt install chromium)")
    out = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--dump-dom",
                          (res.out_dir / "report.html").as_uri()],
                         check=False, capture_output=True, text=True, timeout=180)
    body = re.search(r"<body([^>]*)>", out.stdout).group(1)
    assert 'data-errors="0"' in body and f'data-figures="{len(figures)}"' in body, body
