"""Bad workflows fail with file:line: yaml.path: what was expected, and leave nothing behind."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pipeline.cli import main
from pipeline.core.errors import ConfigError
from pipeline.workflow import load_workflow, run_workflow
from pipeline.workflow.overrides import apply_overrides, parse_assignment

GOOD = """\
name: tiny
gravity: [0, -9.81, 0]
links:
  ground:
    type: ground
    frames:
      O: {origin: [0, 0, 0]}
  arm:
    type: rigid
    mass: 2.0
    com: [0.5, 0, 0]
    inertia: [0.01, 0.2, 0.2, 0, 0, 0]
    frames:
      A: {origin: [0, 0, 0]}
      B: {origin: [1, 0, 0]}
joints:
  - {name: J1, type: revolute, parent: ground.O, child: arm.A, initial: [0.3]}
forces:
  - {name: spring, type: joint_spring_damper, coordinate: J1.theta, stiffness: 5.0}
analyses:
  - name: swing
    type: dynamic
    t_end: 0.5
    outputs: 11
    markers: [arm.B]
outputs:
  plots:
    - {name: angle, analysis: swing, series: [q:J1.theta]}
quick:
  analyses.swing.t_end: 0.1
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "wf.yaml"
    p.write_text(text)
    return p


def _line_of(text: str, needle: str) -> int:
    return next(i + 1 for i, line in enumerate(text.splitlines()) if needle in line)


@pytest.mark.parametrize("old, new, needle, path_text, expect", [
    ("    mass: 2.0", "    mas: 2.0", "mas: 2.0", "links.arm", "unknown key"),
    # the fuzzer's 1e300 as a joint's start overflowed the assembly's least squares
    ("arm.A, initial: [0.3]}", "arm.A, initial: [1.0e300]}", "initial: [1.0e300]",
     "joints[0].initial", "less than or equal to 1000000"),
    ("  - {name: J1, type: revolute, parent: ground.O, child: arm.A, initial: [0.3]}",
     "  - {name: J1, type: revolute, parent: ground.O, child: arm.C, initial: [0.3]}",
     "child: arm.C", "joints[0].child", "has no frame 'C'"),
    ("coordinate: J1.theta", "coordinate: J1.phi", "J1.phi", "forces[0].coordinate",
     "does not exist"),
    ("    t_end: 0.5", "    t_end: -0.5", "t_end: -0.5", "analyses[0].t_end", "greater than 0"),
    ("series: [q:J1.theta]", "series: [q:J9.theta]", "q:J9.theta", "outputs.plots[0]",
     "does not exist"),
    ("stiffness: 5.0}", "stiffnes: 5.0}", "stiffnes", "forces[0]", "unknown field"),
    ("    type: dynamic", "    type: dynamc", "type: dynamc", "analyses[0]", "dynamic"),
    # a render of links that draw nothing (a ground without a shape) crashed after the run
    ("outputs:\n  plots:", ("outputs:\n  renders:\n    - {name: still, analysis: swing, "
     "links: [ground]}\n  plots:"), "links: [ground]", "outputs.renders[0].links",
     "expected at least one link that is drawn"),
    ("outputs:\n  plots:", ("outputs:\n  renders:\n    - {name: still, analysis: swing, "
     "scale: -5}\n  plots:"), "scale: -5", "outputs.renders[0].scale", "greater than 0"),
    ("outputs:\n  plots:", ("outputs:\n  renders:\n    - {name: still, analysis: swing, "
     "camera: [0, 0, 0]}\n  plots:"), "camera: [0, 0, 0]", "outputs.renders[0].camera",
     "a direction [x, y, z] of non-zero length"),
    ("outputs:\n  plots:", ("outputs:\n  animations:\n    - {name: swing, analysis: swing, "
     "links: []}\n  plots:"), "links: []", "outputs.animations[0].links",
     "expected at least one link that is drawn"),
])
def test_errors_name_file_line_and_path(tmp_path, old, new, needle, path_text, expect):
    text = GOOD.replace(old, new)
    assert text != GOOD
    wf_path = _write(tmp_path, text)
    out = tmp_path / "out"
    with pytest.raises(ConfigError) as info:
        run_workflow(wf_path, out_root=out, cache_dir=tmp_path / "cache")
    msg = str(info.value)
    m = re.search(rf"{re.escape(str(wf_path))}:(\d+): ", msg)
    assert m, msg
    line = int(m.group(1))
    # the line of the offending entry (or of the item that contains it)
    assert line <= _line_of(text, needle) and line >= _line_of(text, needle) - 6, msg
    assert path_text in msg and expect in msg, msg
    assert not (out / "tiny").exists()
    assert not any(p.name.startswith(".tiny") for p in out.glob(".*")) if out.exists() else True


def test_good_workflow_runs_and_quick_applies(tmp_path):
    wf = load_workflow(_write(tmp_path, GOOD), quick=True)
    assert wf.spec.analyses[0].t_end == 0.1
    res = run_workflow(wf, out_root=tmp_path / "out", outputs=False)
    r = res.result("swing")
    assert r.success and r.t[-1] == pytest.approx(0.1)
    assert (tmp_path / "out" / "tiny" / "manifest.json").is_file()
    assert res.manifest["status"] == "ok" and res.manifest["quick"] is True


def test_set_overrides_address_items_by_name_and_dotted_keys():
    data = {"analyses": [{"name": "a", "t_end": 1.0}, {"name": "b", "t_end": 2.0}],
            "drivers": {"LUFF.theta": {"type": "constant", "value": 1.0}}}
    out = apply_overrides(data, [parse_assignment("analyses.b.t_end=0.5"),
                                 parse_assignment("drivers.LUFF.theta.value=[1, 2]")])
    assert out["analyses"][1]["t_end"] == 0.5 and out["analyses"][0]["t_end"] == 1.0
    assert out["drivers"]["LUFF.theta"]["value"] == [1, 2]
    assert data["analyses"][1]["t_end"] == 2.0  # input untouched
    with pytest.raises(ConfigError, match="no item named 'c'"):
        apply_overrides(data, [("analyses.c.t_end", 1.0)])
    with pytest.raises(ConfigError, match="expected path=value"):
        parse_assignment("analyses.b.t_end")


def test_set_value_is_data_not_code(tmp_path):
    # a would-be expression stays a string, which the schema then rejects
    with pytest.raises(ConfigError, match="links.arm.mass"):
        load_workflow(_write(tmp_path, GOOD), sets=["links.arm.mass=__import__('os').getpid()"])


def test_cli_validate_and_error_exit_code(tmp_path, capsys):
    p = _write(tmp_path, GOOD)
    assert main(["validate", str(p)]) == 0
    assert "valid workflow 'tiny'" in capsys.readouterr().out
    bad = _write(tmp_path, GOOD.replace("    mass: 2.0", "    mass: -2.0"))
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:{_line_of(GOOD, 'mass: 2.0')}: links.arm" in err


def test_exponent_floats_without_a_dot_or_sign_are_numbers(tmp_path):
    # YAML 1.1 (PyYAML) reads 5e1 as a string; engineers write it as a number
    wf = load_workflow(_write(tmp_path, GOOD.replace("stiffness: 5.0}", "stiffness: 5e1}")),
                       sets=["analyses.swing.t_end=2e-1"])
    assert wf.spec.forces[0].model_extra["stiffness"] == 50.0
    assert wf.spec.analyses[0].t_end == 0.2
    quoted = load_workflow(_write(tmp_path, GOOD.replace("stiffness: 5.0}", "stiffness: '5e1'}")))
    assert quoted.spec.forces[0].model_extra["stiffness"] == "5e1"  # quoted stays text


def test_a_union_reports_the_branch_the_input_took(tmp_path):
    """``modes`` is a count, a list or a rule: a wrong rule gets the rule's error, not also
    'Input should be a valid integer / list' from the branches its mapping never was."""
    text = GOOD.replace("forces:", "rule:\n  modes: {effective_mass: 1.5}\nforces:", 1)
    from pydantic import BaseModel, Field

    from pipeline.workflow.yaml_io import config_error, load_yaml

    class Rule(BaseModel):
        effective_mass: float = Field(le=1)

    class Holder(BaseModel):
        modes: int | list[int] | Rule

    data, lines = load_yaml(_write(tmp_path, text))
    from pydantic import ValidationError

    with pytest.raises(ValidationError) as info:
        Holder.model_validate(data["rule"])
    msg = str(config_error(info.value, "wf.yaml", data["rule"], lines))
    assert msg.count("\n") == 0 and "modes.effective_mass: Input should be less than or " \
                                      "equal to 1" in msg, msg
    with pytest.raises(ValidationError) as info:  # a key missing from the rule
        Holder.model_validate({"modes": {}})
    msg = str(config_error(info.value, "wf.yaml", {"modes": {}}, {}))
    assert msg == "wf.yaml:1: modes.effective_mass: Field required", msg
    with pytest.raises(ValidationError) as info:  # a wrong scalar: every branch's say is kept
        Holder.model_validate({"modes": "three"})
    assert str(config_error(info.value, "wf.yaml", {"modes": "three"}, {})).count("\n") == 2


def test_render_times_outside_the_run_are_drawn_at_the_nearest_and_said(tmp_path, caplog):
    """A still asked at times the run does not reach (a --quick run, a run stopped early, a
    typo) shows the nearest outputs, labelled with their own times, and says so."""
    text = GOOD.replace("outputs:\n  plots:", "outputs:\n  renders:\n    - {name: still, "
                        "analysis: swing, at: [0.05, 5.0, -1.0]}\n  plots:")
    with caplog.at_level("WARNING"):
        run_workflow(_write(tmp_path, text), out_root=tmp_path / "out",
                     cache_dir=tmp_path / "cache")
    assert (tmp_path / "out" / "tiny" / "still.png").exists()
    assert re.search(r"render 'still': at \[5.0, -1.0\] s is outside the outputs of 'swing' "
                     r"\(0 to 0.5 s\)", caplog.text), caplog.text


def test_a_number_out_of_range_is_not_told_the_words_it_could_be():
    """``scale: -1`` (a number or "auto"): 'greater than 0', not also "should be 'auto'"; a
    word that is neither keeps both."""
    from typing import Annotated, Literal

    from pydantic import BaseModel, Field, ValidationError

    from pipeline.workflow.yaml_io import config_error

    class Render(BaseModel):
        scale: Annotated[float, Field(gt=0)] | Literal["auto"]

    for value, expected in ((-1.0, ["Input should be greater than 0"]),
                            ("big", ["Input should be a valid number", "Input should be 'auto'"])):
        with pytest.raises(ValidationError) as info:
            Render.model_validate({"scale": value})
        msg = str(config_error(info.value, "wf.yaml", {"scale": value}, {}))
        said = [line.split(": ", 2)[2] for line in msg.splitlines()]
        assert len(said) == len(expected) and all(
            a.startswith(b) for a, b in zip(said, expected, strict=True)), msg


REACH = """\
name: reach
gravity: [0, -9.81, 0]
links:
  ground: {type: ground, frames: {O: {origin: [0, 0, 0]}, S: {origin: [0.5, -1.0, 0]}}}
  boom:
    type: rigid
    mass: 10.0
    inertia: [1, 1, 1, 0, 0, 0]
    frames: {O: {origin: [0, 0, 0]}, LUG: {origin: [1.0, 0, 0]}}
  barrel:
    type: rigid
    mass: 1.0
    inertia: [0.1, 0.1, 0.1, 0, 0, 0]
    frames:
      FOOT: {origin: [0, 0, 0]}
      AXIS: {origin: [0, 0, 0], z: [1, 0, 0], x: [0, 0, 1]}
  rod:
    type: rigid
    mass: 1.0
    inertia: [0.1, 0.1, 0.1, 0, 0, 0]
    frames:
      END: {origin: [0, 0, 0]}
      AXIS: {origin: [0, 0, 0], z: [1, 0, 0], x: [0, 0, 1]}
joints:
  - {name: BOOM, type: revolute, parent: ground.O, child: boom.O, initial: [0.3]}
  - {name: FOOT, type: revolute, parent: ground.S, child: barrel.FOOT, initial: [1.2]}
  - {name: CYL, type: prismatic, parent: barrel.AXIS, child: rod.AXIS, initial: [1.3]}
  - {name: END, type: revolute, parent: rod.END, child: boom.LUG}
# the boom cylinder, from its foot pin S to the boom's lug, 1 m from the boom's pin O
drivers:
  CYL.d: {type: smooth_step, t0: 0.0, t1: 1.0, v0: 2.5, v1: 1.5}
analyses:
  - {name: hold, type: static}
"""


@pytest.mark.parametrize("stroke, edge", [(2.5, "2.11803"), (0.05, "0.118034")])
def test_a_stroke_out_of_reach_names_the_driver_and_the_reachable_range(tmp_path, capsys,
                                                                       stroke, edge):
    """Issue 24, seen 6: a cylinder too long (or too short) to close its loop at t = 0 read
    "driven coordinates [...] over-constrain the mechanism", or "cannot close", at the top
    of a file without ``initial:``. Nothing is over-driven: the stroke is out of reach. The
    lug swings on a 1 m circle about O, whose distance from S is sqrt(1.25), so the loop
    closes for strokes from sqrt(1.25) - 1 to sqrt(1.25) + 1."""
    p = _write(tmp_path, REACH.replace("v0: 2.5", f"v0: {stroke}"))
    assert main(["validate", str(p), "--build"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {p}:{_line_of(REACH, 'CYL.d: {type')}: drivers.CYL.d: ")
    assert f"CYL.d = {stroke:g} m at t = 0 is out of reach" in err
    assert "from 0.118034 to 2.11803 m" in err and edge in err
    assert "over-constrain" not in err and "\n" not in err
    lo, hi = 1.25 ** 0.5 - 1.0, 1.25 ** 0.5 + 1.0
    assert (f"{lo:.6g}", f"{hi:.6g}") == ("0.118034", "2.11803")
    # within reach, the same machine builds
    assert main(["validate", str(_write(tmp_path, REACH.replace("v0: 2.5", "v0: 2.0"))),
                 "--build"]) == 0


def test_a_stroke_is_in_metres_whatever_the_machine_s_length_scale(tmp_path, capsys):
    """The machine's length scale (its largest frame offset) exactly 1 m: a cylinder's
    stroke was told in rad, a length being recognised by its unit differing from 1. The
    foot at (0.6, -0.8) is 1 m from the boom's pin, the lug 0.5 m out: strokes from 0.5
    to 1.5 m close."""
    text = REACH.replace("S: {origin: [0.5, -1.0, 0]}", "S: {origin: [0.6, -0.8, 0]}") \
        .replace("LUG: {origin: [1.0, 0, 0]}", "LUG: {origin: [0.5, 0, 0]}")
    p = _write(tmp_path, text)
    assert main(["validate", str(p), "--build"]) == 2
    err = capsys.readouterr().err
    assert "CYL.d = 2.5 m at t = 0 is out of reach: the loops close only for CYL.d from " \
           "0.5 to 1.5 m" in err, err
