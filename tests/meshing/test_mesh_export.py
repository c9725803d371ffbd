"""A link meshed here, written for another FE tool and read back (issue 28 done-when: "a
gmsh-made link exported as .inp and re-imported gives the native artifact's invariants to
1e-10"): the same nodes in the same order, so the same K, M, modes and invariants."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from calculix_box import dat_frequencies, run_calculix

pytest.importorskip("gmsh")

from pipeline.core.errors import ConfigError

SPEC = """name: bar
geometry: {GEOMETRY}
material: {E: 70.0e9, nu: 0.33, rho: 2700}
interfaces:
  - name: root
    selector: {type: plane, point: [0, 0, 0], normal: [1, 0, 0]}
    origin: [0, 0, 0]
    z_axis: [0, 1, 0]
    x_axis: [1, 0, 0]
  - name: tip
    selector: {type: plane, point: [0.3, 0, 0], normal: [1, 0, 0]}
    origin: [0.3, 0, 0]
    kind: rbe3
markers:
  - {name: mid, position: [0.15, 0, 0]}
reference: root
modes: {count: 6}
"""
NATIVE = "{type: solid, recipe: bar, params: {L: 0.3, b: 0.01, h: 0.02}, mesh_size: 0.006}"


def _reduce(tmp_path, geometry: str, name: str):
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    p = tmp_path / f"{name}.yaml"
    p.write_text(SPEC.replace("{GEOMETRY}", geometry))
    return reduce_spec(load_link_spec(p), tmp_path, tmp_path / f"links_{name}")[0]


@pytest.mark.parametrize("suffix", [".inp", ".bdf", ".msh", ".vtu"])
def test_a_link_written_and_read_back_is_the_same_link(tmp_path, suffix):
    from pipeline.invariants.mesh_export import write_link_mesh

    native = _reduce(tmp_path, NATIVE, "native")
    assert not np.allclose(native.body_pose[:3, :3], np.eye(3))  # a turned body frame
    write_link_mesh(native, tmp_path / f"bar{suffix}")
    back = _reduce(tmp_path, f"{{type: mesh, path: bar{suffix}, units: m}}", "back")
    assert back.nodes.shape == native.nodes.shape
    # (the .inp's coordinates fit CalculiX's 20-character fields: 16-17 digits here; the
    # .bdf's Nastran's 16: 12-15 digits)
    atol = 1e-13 if suffix == ".bdf" else 1e-15
    np.testing.assert_allclose(back.nodes, native.nodes, rtol=0, atol=atol)
    np.testing.assert_allclose(back.body_pose, native.body_pose, atol=atol)
    # the mass invariants to 1e-10 (measured: .msh and .vtu bit-equal; .inp 8.5e-12); a
    # .bdf's coordinates in Nastran's 16 characters move the modes' C' by 1.2e-10
    tol = 1e-9 if suffix == ".bdf" else 1e-10
    for name in ("C", "Cp", "Cpp"):
        a, b = getattr(back, name), getattr(native, name)
        assert np.abs(a - b).max() <= tol * np.abs(b).max(), name
    # (the marker "mid" sits where a symmetric mesh has nodes tied for its 12th nearest:
    # it takes them all, so 13 digits of the .bdf pick the same nodes; it moved 8e-4)
    for fa, fb in zip(back.frames, native.frames, strict=True):
        assert fa.name == fb.name
        np.testing.assert_allclose(fa.phi, fb.phi, atol=tol * np.abs(fb.phi).max())
    # an .inp holds a coordinate in the 20 characters CalculiX reads (15-17 digits, ~1e-17 m
    # off here); the first eigenvalue moves by up to lambda_max / lambda_1 times that's
    # relative share: 3.2e-10 measured (.bdf, 5e-14 m off: 3.8e-10)
    rtol = {".inp": 1e-9, ".bdf": 1e-7}.get(suffix, 1e-12)
    np.testing.assert_allclose(back.frequencies_hz, native.frequencies_hz, rtol=rtol)
    np.testing.assert_allclose(back.modal_stiffness, native.modal_stiffness, rtol=0,
                               atol=2 * rtol * np.abs(native.modal_stiffness).max())
    S, S0 = back.stress_modes, native.stress_modes
    assert np.abs(S - S0).max() <= 1e-6 * np.abs(S0).max()  # float32 on both sides


def test_only_a_solid_link_is_written_and_by_a_known_suffix(tmp_path):
    from pipeline.invariants.mesh_export import write_link_mesh

    native = _reduce(tmp_path, NATIVE, "native")
    with pytest.raises(ConfigError, match=r"bar\.stl: a link's mesh is written as \.inp"):
        write_link_mesh(native, tmp_path / "bar.stl")


@pytest.mark.skipif(__import__("shutil").which("ccx") is None,
                    reason="CalculiX (apt calculix-ccx) absent")
def test_calculix_runs_the_written_deck_to_the_same_frequencies(tmp_path):
    """The .inp goes to CalculiX as it is (C3D10 in element set BAR, the interfaces' nodes
    in node sets), given a material and a clamp of the written root set (SI units, as
    written): its clamped frequencies are the link's (the rbe2 root is that clamp; the
    rbe3 tip adds no stiffness), to the 3e-5 the two codes' elements differ by on the box
    of test_mesh_import."""
    from pipeline.invariants.mesh_export import write_link_mesh

    native = _reduce(tmp_path, NATIVE, "native")
    path = write_link_mesh(native, tmp_path / "ccx" / "bar.inp")
    text = path.read_text()
    assert "*ELEMENT, TYPE=C3D10, ELSET=BAR" in text
    H = native.body_pose
    x = (native.nodes @ H[:3, :3].T + H[:3, 3])[:, 0]
    root = np.flatnonzero(np.abs(x) < 1e-9) + 1  # the root face's nodes, 1-based
    written = text.split("*NSET, NSET=root\n")[1].split("*")[0]
    assert sorted(map(int, written.replace(",", " ").split())) == root.tolist()
    text += ("*MATERIAL, NAME=AL\n*ELASTIC\n7.0e10, 0.33\n*DENSITY\n2700.\n"
             "*SOLID SECTION, ELSET=BAR, MATERIAL=AL\n*STEP\n*FREQUENCY\n4\n"
             "*BOUNDARY\nroot, 1, 3\n*END STEP\n")
    ref = dat_frequencies(run_calculix(path.parent, text, "bar"), 4)
    np.testing.assert_allclose(native.frequencies_hz[:4], ref, rtol=3e-5)


BOOM = """name: boom
geometry: {GEOMETRY}
material: {E: 2.1e11, nu: 0.3, rho: 7850}
interfaces:
  - {name: foot, selector: {type: group, name: bore_foot}, origin: [0.05, 0, 0]}
  - {name: tip, selector: {type: group, name: bore_tip}, origin: [0.55, 0, 0]}
reference: foot
modes: {count: 4, craig_bampton: true}
"""
BOX = ("{type: solid, recipe: box_section, params: {length: 0.6, b: 0.1, h: 0.08, wall: 0.01, "
       "end_plates: true, cross_bores: [{name: foot, x: 0.05, radius: 0.015, axis: z}, "
       "{name: tip, x: 0.55, radius: 0.015, axis: z}]}, mesh_size: 0.02}")


def test_the_groups_a_spec_selects_go_out_as_node_sets_and_select_again(tmp_path):
    """A boom whose pins are gmsh groups (bore_foot, bore_tip): the written .inp names
    their nodes (and the interfaces'), so the spec reads it back unchanged but for its
    geometry, to the same link."""
    from pipeline.invariants.mesh_export import node_sets, write_link_mesh
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    def reduce(geometry, name):
        p = tmp_path / f"{name}.yaml"
        p.write_text(BOOM.replace("{GEOMETRY}", geometry))
        return reduce_spec(load_link_spec(p), tmp_path, tmp_path / f"links_{name}")[0]

    native = reduce(BOX, "native")
    sets = node_sets(native)
    assert list(sets) == ["bore_foot", "foot", "bore_tip", "tip"]
    assert sets["bore_foot"] is sets["foot"] and sets["bore_foot"].size > 20
    write_link_mesh(native, tmp_path / "boom.inp")
    back = reduce("{type: mesh, path: boom.inp, units: m}", "back")
    for a, b in zip(node_sets(back).values(), sets.values(), strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_allclose(back.frequencies_hz, native.frequencies_hz, rtol=1e-9)
    for name in ("C", "Cp", "Cpp"):
        a, b = getattr(back, name), getattr(native, name)
        assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max(), name


@pytest.mark.slow
@pytest.mark.skipif(__import__("shutil").which("ccx") is None,
                    reason="CalculiX (apt calculix-ccx) absent")
def test_calculix_gives_the_box_section_booms_frequencies_on_its_written_set(tmp_path):
    """The hollow boom above (a 100 x 80 mm box section, 10 mm walls, closed ends, pin
    bores) clamped at its foot bore: CalculiX runs the written .inp, clamping the written
    bore_foot set, to the link's clamped frequencies (the rbe2 foot is that clamp; the tip,
    rbe3 here, adds no stiffness). Measured: 3.7e-5, 4.2e-6, 9.0e-6, 1.7e-6 (the bores'
    elements have curved sides, midside nodes on the circle, which the two codes integrate
    by different rules; the straight bar agrees to 2.4e-7); bounded at 1e-4."""
    from pipeline.invariants.mesh_export import write_link_mesh
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    p = tmp_path / "boom.yaml"
    p.write_text(BOOM.replace("{GEOMETRY}", BOX)
                 .replace("origin: [0.55, 0, 0]}", "origin: [0.55, 0, 0], kind: rbe3}")
                 .replace("modes: {count: 4, craig_bampton: true}", "modes: {count: 4}"))
    native = reduce_spec(load_link_spec(p), tmp_path, tmp_path / "links")[0]
    path = write_link_mesh(native, tmp_path / "ccx" / "boom.inp")
    ref = dat_frequencies(run_calculix(path.parent, path.read_text() + (
        "*MATERIAL, NAME=STEEL\n*ELASTIC\n2.1e11, 0.3\n*DENSITY\n7850.\n"
        "*SOLID SECTION, ELSET=BOOM, MATERIAL=STEEL\n*STEP\n*FREQUENCY\n4\n"
        "*BOUNDARY\nbore_foot, 1, 3\n*END STEP\n"), "boom"), 4)
    # the two bending modes (Euler-Bernoulli with a full clamp at the bore: 284 and
    # 343 Hz; held at the bore's surface only, the root is softer)
    assert 150.0 < ref[0] < ref[1] < 300.0
    np.testing.assert_allclose(native.frequencies_hz[:4], ref, rtol=1e-4)
