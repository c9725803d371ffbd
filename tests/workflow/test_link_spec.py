"""Link-spec validation: every error names file, line, YAML path and expectation."""

import textwrap

import pytest

from pipeline.core.errors import ConfigError
from pipeline.workflow.link_spec import load_link_spec

GOOD = """\
name: bar
geometry:
  type: solid
  recipe: bar
  params: {L: 0.4, b: 0.008, h: 0.004}
  mesh_size: 0.004
material: {E: 70.0e9, nu: 0.3, rho: 2700}
interfaces:
  - name: root
    selector: {type: plane, point: [0, 0, 0], normal: [1, 0, 0]}
  - name: tip
    selector: {type: plane, point: [0.4, 0, 0], normal: [1, 0, 0]}
reference: root
modes: {count: 6}
"""


def _write(tmp_path, text):
    p = tmp_path / "link.yaml"
    p.write_text(textwrap.dedent(text))
    return p


def test_good_spec_loads(tmp_path):
    spec = load_link_spec(_write(tmp_path, GOOD))
    assert spec.name == "bar" and spec.geometry.order == 2
    assert spec.interfaces[0].kind == "rbe2"


@pytest.mark.parametrize(
    "old,new,expected",
    [
        ("mesh_size: 0.004", "mesh_sise: 0.004", r"link.yaml:6: geometry.mesh_sise: unknown key"),
        ("rho: 2700", "rho: -1", r"link.yaml:7: material.rho: Input should be greater than 0"),
        ("nu: 0.3", "nu: 0.5", r"link.yaml:7: material.nu: Input should be less than 0.5"),
        ("reference: root", "reference: hub",
         r"link.yaml:13: reference: .*expected one of the interfaces \['root', 'tip'\], got 'hub'"),
        ("type: plane, point: [0, 0, 0]", "type: plain, point: [0, 0, 0]",
         r"link.yaml:10: interfaces\[0\].selector: Input tag 'plain'"),
        ("modes: {count: 6}", "modes: {craig_bampton: true}",
         r"link.yaml:14: modes: .*modes.count or modes.f_max"),
        # rules between the modes' settings and the interfaces, met before any meshing
        ("modes: {count: 6}", "modes: {count: 0}",
         r"link.yaml:14: modes: .*count 0 needs craig_bampton"),
        ("modes: {count: 6}", "modes: {count: 2, chord: tip, craig_bampton: true}",
         r"link.yaml:14: modes: .*chord and .*craig_bampton exclude each other"),
        ("modes: {count: 6}", "modes: {count: 2, chord: hub}",
         (r"link.yaml:14: modes: chord: expected one of the interfaces other than the "
         r"reference \['tip'\], got 'hub'")),
        ("reference: root", "reference: root\nmarkers:\n  - {name: root, position: [0.2, 0, 0]}",
         (r"link.yaml:15: markers: duplicate frame name\(s\) \['root'\] among interfaces and "
         r"markers")),
        ("  - name: tip\n", "  - name: root\n",
         r"link.yaml:9: interfaces: duplicate frame name\(s\) \['root'\]"),
        ("modes: {count: 6}", "modes: {count: 2, chord: root}",
         r"link.yaml:14: modes: chord: .*got 'root'"),
    ],
)
def test_bad_specs_name_line_and_path(tmp_path, old, new, expected):
    assert old in GOOD
    with pytest.raises(ConfigError, match=expected):
        load_link_spec(_write(tmp_path, GOOD.replace(old, new)))


def test_duplicate_key_and_syntax_error(tmp_path):
    with pytest.raises(ConfigError, match=r":14: reference: duplicate key"):
        load_link_spec(_write(tmp_path, GOOD.replace("modes:", "reference: tip\nmodes:")))
    with pytest.raises(ConfigError, match=r"link.yaml:\d+: invalid YAML"):
        load_link_spec(_write(tmp_path, GOOD + "  bad: [1, 2\n"))
    with pytest.raises(ConfigError, match="file not found"):
        load_link_spec(tmp_path / "nope.yaml")


@pytest.mark.parametrize("message, where", [
    ("link 'bar': sections[0].members: member 1 out of range 0..0", "sections[0].members"),
    ("link 'bar': geometry.points: member 0 has zero length", "geometry"),
    ("link 'bar': modes.chord: expected two RBE2 interfaces", "modes"),
    ("link 'bar': craig_bampton needs at least one RBE2 interface besides 'root'", "modes"),
    ("link 'bar': interface 'tip': selector matched no node", "interfaces[1]"),
    ("link 'bar': 2 modes carry no mass", "<root>"),  # a word is not a path
])
def test_errors_met_while_reducing_name_the_spec_line(tmp_path, message, where):
    """What the reduction says is placed at the line of the key it names (the spec
    validated, the error met in meshing or reduction)."""
    from pipeline.workflow.link_spec import load_link_spec_lines, locate

    text = GOOD.replace("modes: {count: 6}", "sections:\n  - {A: 1.0e-4, Iy: 1.0e-9, Iz: 1.0e-9, "
                        "J: 2.0e-9, members: [0]}\nmodes: {count: 6}")
    path = _write(tmp_path, text)
    spec, lines = load_link_spec_lines(path)
    out = locate(message, spec, path, lines)
    assert out.startswith(f"{path}:") and f": {where}: {message}" in out, out
    key_line = {"sections[0].members": 15, "geometry": 3, "modes": 16, "interfaces[1]": 11,
                "<root>": 1}[where]
    assert out.split(":")[1] == str(key_line), out
