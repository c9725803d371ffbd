"""A model that is too stiff for its machine says so (issue 24): a boom pinned at its root
and propped by a strut at a lug, loaded at its tip. Clamped at its root bore, its lowest
mode is nearly the rotation the root pin already allows, and the strut forbids both: one
kept mode carries a fraction of the tip's flexibility. The check's figure is that
fraction -- the ratio of the tip deflections of the kept-mode model and of an exact one
(Craig-Bampton with every mode: the full FE statics at the interfaces), which itself
equals the overhanging beam's closed form P b^2 (a + b) / 3 EI."""

from __future__ import annotations

import pytest
from link_samples import boom_spec

from pipeline.invariants.adequacy import constrained_coverage, frame_motions
from pipeline.workflow import build_machine, load_workflow
from pipeline.workflow.analyses import run_analysis
from pipeline.workflow.model_checks import machine_conditions
from pipeline.workflow.series import marker_positions

L, A_PIN, E, IZ, P = 2.0, 0.8, 2.1e11, 1.0e-6, 1.0


def _boom(neck_iz: float, modes: str) -> str:
    """A beam boom along x with a 5 cm root segment of second moment ``neck_iz`` (a small,
    soft bore: the knuckle boom of the report)."""
    return boom_spec(L, A_PIN, A=1.0e-3, Iy=4.0e-6, Iz=IZ, J=4.0e-6, E=E, modes=modes,
                     neck_iz=neck_iz)


WORKFLOW = f"""\
name: propped
gravity: [0, 0, 0]
links:
  ground: {{type: ground, frames: {{O: {{origin: [0, 0, 0]}}, S: {{origin: [{A_PIN}, -1.0, 0]}}}}}}
  boom: {{type: flexible, spec: boom.yaml, modes: 1, plane: xy}}
  strut:
    type: rigid
    mass: 1.0
    inertia: [0.01, 0.01, 0.01, 0, 0, 0]
    frames: {{B: {{origin: [0, 0, 0]}}, T: {{origin: [0, 1.0, 0]}}}}
joints:
  - {{name: R, type: revolute, parent: ground.O, child: boom.root}}
  - {{name: S, type: revolute, parent: ground.S, child: strut.B}}
  - {{name: T, type: revolute, parent: strut.T, child: boom.pin}}
forces:
  - {{name: load, type: point_force, marker: boom.tip, force: [0, {-P}, 0]}}
analyses:
  - {{name: sag, type: static}}
"""


def _run(tmp_path, neck_iz, modes, sets=()):
    (tmp_path / "boom.yaml").write_text(_boom(neck_iz, modes))
    (tmp_path / "propped.yaml").write_text(WORKFLOW)
    m = build_machine(load_workflow(tmp_path / "propped.yaml", sets=list(sets)),
                      tmp_path / "links")
    r = run_analysis(m, "sag")
    return m, r, marker_positions(m.mechanism, r.q, "boom", "tip")[-1, 1]


def _tip_coverage(m) -> float:
    rows, held, _ = machine_conditions(m.workflow, m, "boom", "xy")
    _, G, K, C = frame_motions(m.parts["boom"].reduced, m.parts["boom"].modes)
    cover = constrained_coverage(G, K, C, rows, held)
    return next(c.ratio for c in cover if (c.frame, c.direction) == ("tip", "y"))


@pytest.mark.parametrize("neck_iz", [IZ, IZ / 100])
def test_a_basis_too_stiff_for_its_supports_is_suspect_and_its_figure_is_the_deflection_ratio(
        tmp_path, neck_iz):
    _, exact_r, exact = _run(tmp_path, neck_iz, "{count: 8, craig_bampton: true}",
                             ["links.boom.modes=null"])
    assert exact_r.verdict == "ok", exact_r.warnings
    if neck_iz == IZ:  # uniform: the overhanging beam's closed form
        b = L - A_PIN
        assert exact == pytest.approx(-P * b ** 2 * L / (3 * E * IZ), rel=1e-5)
    m, r, tip = _run(tmp_path, neck_iz, "{count: 8}")
    share = tip / exact
    assert share < 0.6  # one clamped mode: 49 % (uniform), 8 % (soft root)
    assert _tip_coverage(m) == pytest.approx(share, abs=2e-3)
    assert r.verdict == "suspect"
    (line,) = m.model_warnings
    assert line in r.warnings
    assert "link 'boom', on the machine's supports" in line and "at 'tip'" in line
    assert f"y {100 * share:.0f} %" in line and "craig_bampton: true" in line
    # two modes carry the bending between the supports: ok, and within 2 % of exact
    m2, r2, tip2 = _run(tmp_path, neck_iz, "{count: 8}", ["links.boom.modes=2"])
    assert r2.verdict == "ok" and not m2.model_warnings, m2.model_warnings
    assert tip2 / exact == pytest.approx(_tip_coverage(m2), abs=2e-3)
    assert tip2 / exact > 0.98


@pytest.mark.parametrize("offset", [0.0, 0.4])
def test_a_workflow_frame_fixed_on_an_interface_loads_that_interface(tmp_path, offset):
    """The strut pinned to a frame the workflow fixes on the 'pin' interface (``offset`` m
    further along the boom, the strut moved with it): the check reads the load there
    through the interface's motion carried rigidly to the frame, and its figure is again
    the ratio of the tip deflections."""
    lug = WORKFLOW.replace(
        "boom: {type: flexible, spec: boom.yaml, modes: 1, plane: xy}",
        "boom: {type: flexible, spec: boom.yaml, modes: 1, plane: xy, "
        f"frames: {{lug: {{on: pin, origin: [{offset}, 0, 0]}}}}}}").replace(
        "child: boom.pin}", "child: boom.lug}").replace(
        f"S: {{origin: [{A_PIN}, -1.0, 0]}}", f"S: {{origin: [{A_PIN + offset}, -1.0, 0]}}")
    assert lug != WORKFLOW

    def run(modes, sets=()):
        (tmp_path / "boom.yaml").write_text(_boom(IZ / 100, modes))
        (tmp_path / "lug.yaml").write_text(lug)
        m = build_machine(load_workflow(tmp_path / "lug.yaml", sets=list(sets)),
                          tmp_path / "links")
        r = run_analysis(m, "sag")
        return m, r, marker_positions(m.mechanism, r.q, "boom", "tip")[-1, 1]

    _, _, exact = run("{count: 8, craig_bampton: true}", ["links.boom.modes=null"])
    m, r, tip = run("{count: 8}")
    assert r.verdict == "suspect" and "at 'tip'" in m.model_warnings[0]
    assert _tip_coverage(m) == pytest.approx(tip / exact, abs=2e-3)
