"""``pipeline reduce``: summary output and clear errors with nothing half-written."""

import json
import re

import pytest
from link_samples import beam_spec, write_bar

from pipeline.cli import main

pytestmark = pytest.mark.gmsh


def test_reduce_prints_json_summary_and_reuses(tmp_path, capsys):
    spec = write_bar(tmp_path, modes=3)
    out = tmp_path / "links"
    assert main(["reduce", str(spec), "--out", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["cache"] == "miss" and s["n_modes"] == 3 and s["dof"] > 0
    assert s["mass_kg"] == pytest.approx(2700 * 0.2 * 0.02 * 0.01, rel=1e-10)
    assert set(s["stage_seconds"]) >= {"meshing link 'bar'", "eigen solve of link 'bar'",
                                       "stress modes of link 'bar'"}
    assert s["factorisation"] == "SuperLU"  # a small link; CHOLMOD from 100 k DOF
    assert s["peak_memory_mib"] > 50  # the process holds numpy, scipy, gmsh at least
    assert s["reference_conditions"] == "clamped at 'root'" and s["geometric_stiffening"] is None
    assert main(["reduce", str(spec), "--out", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["cache"] == "hit"
    assert main(["reduce", str(spec), "--out", str(out)]) == 0  # rich table
    table = capsys.readouterr().out
    assert "reduced link 'bar'" in table
    assert re.search(r"factorisation of the clamped .*SuperLU", table, re.DOTALL)
    assert re.search(r"peak memory of the process .*\d\.\d\d GiB", table, re.DOTALL)


@pytest.mark.parametrize(
    "edit,expected",
    [
        (("name: end_xL", "name: end_xM"), "interface 'tip'.*end_xM"),
        (("rho: 2700", "rho: 0"), r"material.rho: Input should be greater than 0"),
        (("nu: 0.3", "nu: -1.5"), r"material.nu: Input should be greater than -1"),
        (("modes: {count: 3}", "modes: {count: 100000}"), "modes"),
        (("modes: {count: 3}", ("point_masses:\n  - {name: pm, position: [0.2, 0, 0], mass: 1.0, "
          "inertia: [[1, 2, 0], [0, 1, 0], [0, 0, 1]]}\nmodes: {count: 3}")),
         (r"bar.yaml:23: point_masses\[0\]: link 'bar': point mass 'pm': inertia: expected a "
         r"symmetric")),
        (("radius: 0.01}", "radius: 1.0e-9}"),
         (r"bar.yaml:21: markers\[0\]: .*marker 'mid': no FE node within its radius 1e-09 m "
         r"of \[0.1, 0.0, 0.0\]; the nearest is [0-9.e-]+ m away")),
        # reference conditions the interfaces' kinds do not allow: the modes' line and key
        (("    z_axis: [1, 0, 0]\nreference", ("    z_axis: [1, 0, 0]\n    kind: rbe3\n"
          "reference")), ("modes: {count: 3}", "modes: {count: 3, chord: tip}")),
        (("    z_axis: [1, 0, 0]\nreference", ("    z_axis: [1, 0, 0]\n    kind: rbe3\n"
          "reference")), ("modes: {count: 3}", "modes: {count: 3, craig_bampton: true}")),
        (("recipe: bar\n  params: {L: 0.2, b: 0.02, h: 0.01}", "recipe: geo\n  path: missing.geo"),
         "link 'bar'.*missing.geo"),
        (("type: group, name: end_xL", ("type: cylinder, point: [0.1, 0, 0], axis: [1, 0, 0], "
          "radius: 0.5")), "interface 'tip'.*matched no"),
    ],
)
def test_bad_input_one_clear_error_nothing_written(tmp_path, capsys, edit, expected):
    spec = write_bar(tmp_path, modes=3)
    text = spec.read_text()
    assert edit[0] in text
    text = text.replace(edit[0], edit[1], 1)
    if isinstance(expected, tuple):  # a second edit; the error is at its line and key
        text = text.replace(*expected)
        line = text.splitlines().index(expected[1]) + 1
        expected = rf"bar.yaml:{line}: modes.{expected[1].split(', ')[1].split(':')[0]}: "
    spec.write_text(text)
    out = tmp_path / "links"
    assert main(["reduce", str(spec), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "Traceback" not in err
    assert re.search(expected, err, re.DOTALL), err
    assert not out.exists() or list(out.iterdir()) == []


def test_a_marker_far_from_the_mesh_is_reduced_with_a_warning(tmp_path, caplog):
    """A marker 4.9 m from a 0.2 m bar (a typo: 5 for 0.05) moves as the rigid fit of the
    nodes nearest it, extrapolated: allowed (a lug that is not meshed), but said."""
    spec = write_bar(tmp_path, modes=3)
    spec.write_text(spec.read_text().replace("position: [0.1, 0, 0], radius: 0.01",
                                             "position: [5, 0, 0]"))
    with caplog.at_level("WARNING"):
        assert main(["reduce", str(spec), "--out", str(tmp_path / "links")]) == 0
    assert re.search(r"marker 'mid' at \[5.0, 0.0, 0.0\] is 4.8 m from the nearest FE node, "
                     r"24 times the link's size \(0.2 m\)", caplog.text), caplog.text
    caplog.clear()
    spec = write_bar(tmp_path, modes=3, name="near.yaml")  # 5 mm off the surface: silent
    spec.write_text(spec.read_text().replace("position: [0.1, 0, 0]", "position: [0.1, 0.015, 0]"))
    with caplog.at_level("WARNING"):
        assert main(["reduce", str(spec), "--out", str(tmp_path / "links")]) == 0
    assert "nearest FE node" not in caplog.text


@pytest.mark.parametrize("modes, conditions, stiffening", [
    ("{count: 2, chord: tip, geometric_stiffening: true}", ("chord from 'root' to 'tip' "
     "(pinned-pinned)"), "12 inertia cases; forces at root, tip, mid"),
    ("{count: 2, craig_bampton: true}", ("clamped at 'root', with 6 constraint modes "
     "(Craig-Bampton: tip)"), "off"),
])
def test_reduce_says_which_modes_and_which_stiffening(tmp_path, capsys, modes, conditions,
                                                      stiffening):
    """The table and the JSON say what the modes are relative to and whether the link
    carries geometric stiffening (a user choosing between runs reads it there)."""
    spec = tmp_path / "rod.yaml"
    spec.write_text(beam_spec("rod", 0.3, A=7.85e-5, Iy=4.9e-10, Iz=4.9e-10, J=9.8e-10,
                              element_size=0.03, interfaces=("root", "tip"),
                              markers={"mid": 0.15}, modes=modes))
    out = tmp_path / "links"
    assert main(["reduce", str(spec), "--out", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["reference_conditions"] == conditions
    if stiffening == "off":
        assert s["geometric_stiffening"] is None
    else:
        assert s["geometric_stiffening"] == {"inertia_cases": 12,
                                             "frame_forces": ["root", "tip", "mid"]}
    assert main(["reduce", str(spec), "--out", str(out)]) == 0
    table = " ".join(re.sub("[│┃]", " ", capsys.readouterr().out).split())  # rich wraps cells
    assert re.search(r"modes relative to .*" + re.escape(conditions.split(" (")[0]), table)
    assert re.search(r"geometric stiffening .*" + re.escape(stiffening.split(";")[0]), table)


def test_reduce_reports_the_static_compliance_its_modes_carry(tmp_path, capsys):
    """One clamped mode of a cantilever bends it in one plane only: the tip's lateral
    compliance in the other plane (a quarter of the first's: Iy = 4 Iz) is missing, and
    the summary says so with the remedy; with two modes both planes are carried."""
    (tmp_path / "beam.yaml").write_text(beam_spec(
        "beam", 1.0, A=1e-4, Iy=4e-8, Iz=1e-8, J=4e-8, element_size=0.05,
        interfaces=("root", "tip"), modes="{count: 1}"))
    assert main(["reduce", str(tmp_path / "beam.yaml"), "--out", str(tmp_path / "l"),
                 "--json"]) == 0
    cov = json.loads(capsys.readouterr().out)["static_coverage"]
    share = {(r["frame"], r["direction"]): r["share"] for r in cov["rows"]}
    assert share[("tip", "y")] == pytest.approx(0.9707, abs=2e-3)  # the first mode's share
    assert share[("tip", "z")] < 1e-9
    (line,) = cov["warnings"]
    assert "link 'beam', held at its reference" in line and "z 0 % at 'tip'" in line
    assert "keep more modes" in line and "craig_bampton" in line
    (tmp_path / "beam.yaml").write_text((tmp_path / "beam.yaml").read_text().replace(
        "modes: {count: 1}", "modes: {count: 2}"))
    assert main(["reduce", str(tmp_path / "beam.yaml"), "--out", str(tmp_path / "l")]) == 0
    table = capsys.readouterr().out
    assert "static compliance" in table and "warning" not in table
