"""A body reduced from another FE code's matrices, in a machine (issue 28, done-when: "a
CalculiX ... substructure of the same boom, imported as a reduced body, gives the same
machine response as the project's own Craig-Bampton reduction of that mesh").

CalculiX's ``*SUBSTRUCTURE GENERATE`` writes a substructure's stiffness only, not its mass,
so a Craig-Bampton body cannot come from it. What CalculiX gives in full is its assembled
free-free K and M (``*FREQUENCY, SOLVER=MATRIXSTORAGE``); the link is reduced here from
those (Craig-Bampton at both pins) and put in a machine beside the same link reduced from
the project's own assembly of the same mesh file: a pendulum of the box with a rigid bob
on its tip pin. Both machines' linearised frequencies about the hanging equilibrium, and a
swing from horizontal, are compared.

The two codes integrate the quadratic tetrahedra's mass differently (the link's clamped
frequencies differ by 2.4e-7 in the first two modes and up to 2.2e-5 in the sixth,
test_mesh_import.py), so the machines agree to that, not to round-off.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from calculix_box import NU, RHO, E, calculix_deck, make_box, run_calculix

pytestmark = [pytest.mark.gmsh, pytest.mark.slow,
              pytest.mark.skipif(shutil.which("ccx") is None,
                                 reason="CalculiX (apt calculix-ccx) absent")]

MATRICES = (", matrices: {format: calculix, stiffness: free/model.sti, mass: free/model.mas, "
            "dofs: free/model.dof, mass_unit: t}")

MACHINE = """name: {name}
gravity: [0, -9.81, 0]
links:
  ground: {{type: ground, frames: {{O: {{origin: [0, 0, 0]}}}}}}
  arm: {{type: flexible, spec: {spec}, modes: 10}}
  bob:
    type: rigid
    mass: 0.5
    com: [0.05, 0, 0]
    inertia: [1.0e-4, 4.0e-4, 4.0e-4, 0, 0, 0]
    frames: {{PIN: {{origin: [0, 0, 0]}}}}
joints:
  - {{name: J1, type: revolute, parent: ground.O, child: arm.pivot}}
  - {{name: J2, type: revolute, parent: arm.tip, child: bob.PIN}}
analyses:
  - name: modes
    type: linearised
    start: static
    initial: {{coordinates: {{J1.theta: -1.5707963267948966}}}}
    count: 6
  - {{name: swing, type: dynamic, t_end: 0.1, outputs: 21, rtol: 1.0e-8, atol: 1.0e-10}}
"""


def _link(path: Path, extra: str) -> None:
    path.write_text(f"""name: {path.stem}
geometry: {{type: mesh, path: free/model.inp, units: mm{extra}}}
material: {{E: {E}, nu: {NU}, rho: {RHO}}}
interfaces:
  - {{name: pivot, selector: {{type: plane, point: [0, 0.01, 0.005], normal: [1, 0, 0]}},
     origin: [0, 0.01, 0.005], z_axis: [0, 0, 1], x_axis: [1, 0, 0]}}
  - {{name: tip, selector: {{type: plane, point: [0.4, 0.01, 0.005], normal: [1, 0, 0]}},
     origin: [0.4, 0.01, 0.005], z_axis: [0, 0, 1], x_axis: [1, 0, 0]}}
reference: pivot
modes: {{count: 4, craig_bampton: true}}
""")


@pytest.fixture(scope="module")
def machines(tmp_path_factory):
    """The pendulum run with the box reduced from its mesh and from CalculiX's matrices."""
    from pipeline.workflow.run import run_workflow

    tmp = tmp_path_factory.mktemp("calculix_machine")
    run_calculix(tmp / "free", calculix_deck(make_box(), clamped=False, storage=True),
                 "model")
    out = {}
    for name, extra in (("native", ""), ("calculix", MATRICES)):
        _link(tmp / f"{name}_box.yaml", extra)
        wf = tmp / f"{name}.yaml"
        wf.write_text(MACHINE.format(name=name, spec=f"{name}_box.yaml"))
        out[name] = run_workflow(wf, out_root=tmp / "out", cache_dir=tmp / "links",
                                 outputs=False)
    return out


def test_the_link_from_calculix_matrices_is_a_craig_bampton_body(machines):
    for name, res in machines.items():
        assert res.manifest["status"] == "ok", (name, res.manifest["analyses"])
        reduced = res.machine.parts["arm"].reduced
        # 4 fixed-interface modes and the tip pin's 6 constraint modes
        assert reduced.n_modes == 10, (name, reduced.n_modes)
        assert reduced.mass == pytest.approx(RHO * 0.4 * 0.02 * 0.01, rel=1e-9)
    # the matrices were CalculiX's: no element stresses come with them, and that is said
    calculix = machines["calculix"].machine.parts["arm"].reduced
    assert calculix.stress_modes.size == 0 and "unavailable" in calculix.meta["stress"]
    assert machines["native"].machine.parts["arm"].reduced.stress_modes.size


def test_the_machines_frequencies_agree(machines):
    """The two pendulum modes (0.80 and 2.99 Hz) within 1e-10 (measured 4.7e-13 and
    9.9e-11), the four bending modes (22-478 Hz) within 3e-6 (measured 5.9e-7-1.1e-6, as
    the link's own clamped modes differ between the two codes' elements)."""
    f = {k: np.asarray(r.result("modes", "").extra["frequencies_hz"])
         for k, r in machines.items()}
    native, calculix = f["native"], f["calculix"]
    assert native.size == calculix.size == 6
    assert 0.5 < native[0] < 1.0 and 2.0 < native[1] < 4.0 and native[2] > 20.0
    assert np.allclose(calculix[:2], native[:2], rtol=1e-10, atol=0), (calculix, native)
    assert np.allclose(calculix, native, rtol=3e-6, atol=0), (calculix, native)


def test_the_machines_swing_alike(machines):
    """From horizontal for 0.1 s (the bar bends under its own swing and the bob's pull):
    the joint angles within 1.5e-6 of their range (measured 4.2e-7, the bending modes'
    difference; integration at rtol 1e-8). The modal coordinates are not compared: they
    are amplitudes of two different bases."""
    runs = {k: r.result("swing", "") for k, r in machines.items()}
    a, b = runs["native"], runs["calculix"]
    assert a.coordinates == b.coordinates
    joints = [i for i, c in enumerate(a.coordinates) if c.endswith(".theta")]
    scale = np.abs(a.q[:, joints]).max()
    assert scale > 0.01  # it fell
    assert np.abs(a.q[:, joints] - b.q[:, joints]).max() < 1.5e-6 * scale
