"""A model that is too stiff for its machine says so (issue 24): a boom pinned at its root
and propped by a strut at a lug, loaded at its tip. Clamped at its root bore, its lowest
mode is nearly the rotation the root pin already allows, and the strut forbids both: one
kept mode carries a fraction of the tip's flexibility. The check's figure is that
fraction -- the ratio of the tip deflections of the kept-mode model and of an exact one
(Craig-Bampton with every mode: the full FE statics at the interfaces), which itself
equals the overhanging beam's closed form P b^2 (a + b) / 3 EI."""

from __future__ import annotations

import numpy as np
import pytest
from link_samples import boom_spec

from pipeline.invariants.adequacy import constrained_coverage, frame_motions
from pipeline.kinematics.partition import dof_report
from pipeline.workflow import build_machine, load_workflow
from pipeline.workflow.analyses import run_analysis
from pipeline.workflow.model_checks import machine_conditions, machine_plane
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
    rows, held, _, _ = machine_conditions(m.workflow, m, "boom", "xy")
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


PLATE = """\
name: boom
geometry:
  type: solid
  recipe: plate_with_bores
  params:
    length: 2.0
    width: 0.05
    thickness: 0.12
    bores:
      - {name: root, center: [0.05, 0.0], radius: 0.02}
      - {name: pin, center: [0.8, 0.0], radius: 0.02}
      - {name: tip, center: [1.95, 0.0], radius: 0.02}
  mesh_size: 0.03
  order: 2
material: {E: 2.1e11, nu: 0.3, rho: 7850}
interfaces:
  - {name: root, selector: {type: group, name: bore_root}, origin: [0.05, 0, 0]}
  - {name: pin, selector: {type: group, name: bore_pin}, origin: [0.8, 0, 0]}
  - {name: tip, selector: {type: group, name: bore_tip}, origin: [1.95, 0, 0]}
reference: root
modes: {count: 4}
"""

#: the propped boom again, a tall plate meshed with unstructured tetrahedra (not symmetric
#: about its mid-plane) on a spherical rod eye: a planar loop built in 3-D, whose
#: out-of-plane row the rigid joints leave redundant
ROD_EYE = WORKFLOW.replace("spec: boom.yaml, modes: 1, plane: xy}", "spec: boom.yaml, modes: 1}") \
    .replace("O: {origin: [0, 0, 0]}", "O: {origin: [0.05, 0, 0]}") \
    .replace("{name: T, type: revolute,", "{name: T, type: spherical,") \
    .replace(f"force: [0, {-P}, 0]", "force: [0, -1000.0, 0]")


def _plate_run(tmp_path, sets=()):
    (tmp_path / "boom.yaml").write_text(PLATE)
    (tmp_path / "eye.yaml").write_text(ROD_EYE)
    m = build_machine(load_workflow(tmp_path / "eye.yaml", sets=list(sets)), tmp_path / "links")
    r = run_analysis(m, "sag")
    return m, r, marker_positions(m.mechanism, r.q, "boom", "tip")[-1, 1]


@pytest.mark.gmsh
def test_an_asymmetric_mesh_does_not_let_a_planar_loop_lock_its_in_plane_modes(tmp_path):
    """Issue 24, seen 2: the in-plane modes carry 1e-5 of out-of-plane motion at the lug
    (mesh round-off), the rod eye's lateral row acted on nothing else, and the loop held
    the modes at zero (sag exactly 0; one of two modes locked). Now the round-off is no
    motion across the plane, the row is redundant, and the two in-plane modes give the
    Craig-Bampton model's sag."""
    assert ROD_EYE != WORKFLOW and "spherical" in ROD_EYE
    _, exact_r, exact = _plate_run(tmp_path, ["links.boom.modes=null",
                                              "links.boom.spec_overrides.modes={count: 8, "
                                              "craig_bampton: true}"])
    assert exact_r.verdict == "ok", exact_r.warnings
    assert exact < -1e-4
    m, r, tip = _plate_run(tmp_path, ["links.boom.modes=[0, 2]"])
    red = m.parts["boom"].reduced
    lug = red.frame("pin").phi[[0, 2]]
    assert np.all(np.abs(lug[:, 2]) > 1e-7 * np.abs(lug[:, 1]))  # the mesh is asymmetric
    assert "L1 (cut 'T'): position z" in dof_report(m.mechanism, m.q0).redundant
    assert tip / exact == pytest.approx(1.0, abs=0.02), (tip, exact)
    assert r.verdict == "ok", r.warnings


@pytest.mark.gmsh
def test_a_mode_the_loops_really_hold_is_named_with_its_row_and_the_check_reads_the_plane(
        tmp_path):
    """The plate's out-of-plane bending mode alone: the rod eye's lateral row holds it (its
    motion there is real, not round-off). The build names the mode, its frequency and the
    row; the machine moves and loads the boom in its x-y plane, so the basis check reads
    the in-plane tip compliance -- none carried -- and the static run is suspect."""
    m, r, tip = _plate_run(tmp_path, ["links.boom.modes=[1]"])
    assert tip == 0.0
    (note,) = m.model_notes
    f = m.parts["boom"].reduced.frequencies_hz[1]
    assert f"boom.eta1 ({f:.4g} Hz)" in note and "L1 (cut 'T'): position z" in note
    assert "craig_bampton: true" in note
    assert r.verdict == "suspect" and "y 0 % at 'tip'" in r.warnings[-1]
    assert machine_plane(m, "boom") == "xy"
    # kept with the in-plane modes, it is held again, and they carry the sag: ok
    m3, r3, tip3 = _plate_run(tmp_path, ["links.boom.modes=[0, 1, 2]"])
    assert len(m3.model_notes) == 1 and "boom.eta2" in m3.model_notes[0]
    assert r3.verdict == "ok" and tip3 == pytest.approx(_plate_run(
        tmp_path, ["links.boom.modes=[0, 2]"])[2], rel=1e-9)


def test_craig_bampton_truncated_to_the_count_is_the_clamped_model(tmp_path):
    """Why the default basis stays clamped (docs/link_specs.md): the orthonormalised
    Craig-Bampton basis truncated to its lowest vector carries the same tip sag as one
    clamped mode (8 % of the exact, soft root); what helps is keeping more of it (three
    in-plane vectors: 99 %), which the check asks for."""
    _, _, exact = _run(tmp_path, IZ / 100, "{count: 8, craig_bampton: true}",
                       ["links.boom.modes=null"])
    _, _, clamped = _run(tmp_path, IZ / 100, "{count: 8}")
    _, r_cb, cb = _run(tmp_path, IZ / 100, "{count: 8, craig_bampton: true}")
    assert cb == pytest.approx(clamped, rel=1e-4) and cb / exact < 0.1
    assert r_cb.verdict == "suspect"
    _, r3, cb3 = _run(tmp_path, IZ / 100, "{count: 8, craig_bampton: true}",
                      ["links.boom.modes=3"])
    assert cb3 / exact > 0.99 and r3.verdict == "ok"


def test_the_boom_s_own_weight_is_checked_on_its_supports(tmp_path):
    """The propped boom under its own weight alone (the strut nearly massless): one clamped
    mode carries a fraction of the weight's work, and the line says so; the figure is the
    ratio of the elastic energies at static equilibrium (half the work), kept modes against
    16 Craig-Bampton modes, within 1 %."""
    from pipeline.dynamics.energy import energies
    from pipeline.kinematics import evaluate_tree

    text = WORKFLOW.replace("gravity: [0, 0, 0]", "gravity: [0, -9.81, 0]") \
        .replace("    mass: 1.0\n", "    mass: 1.0e-6\n") \
        .replace(f"  - {{name: load, type: point_force, marker: boom.tip, force: [0, {-P}, 0]}}\n",
                 "  []\n").replace("forces:\n  []", "forces: []")
    assert "point_force" not in text and "mass: 1.0e-6" in text

    def run(modes, sets=()):
        (tmp_path / "boom.yaml").write_text(_boom(IZ, modes))
        (tmp_path / "w.yaml").write_text(text)
        m = build_machine(load_workflow(tmp_path / "w.yaml", sets=list(sets)), tmp_path / "l")
        r = run_analysis(m, "sag")
        q, qd = r.q[-1], np.zeros_like(r.q[-1])
        e = energies(m.system, evaluate_tree(m.mechanism, q, qd), q, qd)["elastic"]
        return m, r, e

    _, r_exact, exact = run("{count: 16, craig_bampton: true}", ["links.boom.modes=null"])
    assert r_exact.verdict == "ok", r_exact.warnings
    m, r, lean = run("{count: 8}")
    assert r.verdict == "suspect"
    (line,) = m.model_warnings
    share = lean / exact
    assert share < 0.5 and f"y {100 * share:.0f} % under its own weight and inertia" in line
