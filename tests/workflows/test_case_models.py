"""Outputs of an analysis whose cases build different models (a case that keeps no
modes beside the flexible one): each case's coordinates are drawn with its own machine.
Drawing them all with the first case's machine read past the shorter q (a compiled
kernel aborted the process with 'free(): invalid next size', exit 134)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from link_samples import beam_spec

from pipeline.workflow import build_machine, load_workflow, run_workflow

BAR = beam_spec("cantilever", 1.0, A=1e-4, Iy=4e-8, Iz=1e-8, J=4e-8, E=2.1e11, rho=7850.0,
                element_size=0.1, markers={"tip": 1.0})

WORKFLOW = """\
name: sag
gravity: [0, -9.81, 0]
links:
  ground: {type: ground, frames: {O: {origin: [0, 0, 0]}}}
  bar: {type: flexible, spec: bar.yaml, modes: 3, plane: xy}
joints:
  - {name: J, type: revolute, parent: ground.O, child: bar.root}
forces:
  - {name: s, type: joint_spring_damper, coordinate: J.theta, stiffness: 2000.0}
analyses:
  - name: sag
    type: static
    cases:
      - {label: flexible, set: {}}
      - {label: rigid, set: {links.bar.modes: 0}}
outputs:
  renders:
    - {name: pic, analysis: sag}
"""


def _write(tmp_path, text=WORKFLOW):
    (tmp_path / "bar.yaml").write_text(BAR)
    p = tmp_path / "sag.yaml"
    p.write_text(text)
    return p


def test_a_render_of_cases_with_different_mode_counts_draws_each_with_its_own_machine(tmp_path):
    res = run_workflow(_write(tmp_path), out_root=tmp_path / "out", cache_dir=tmp_path / "links")
    man = json.loads((res.out_dir / "manifest.json").read_text())
    assert man["status"] == "ok", man
    assert "pic.png" in man["files"] and (res.out_dir / "pic.png").stat().st_size > 0


def test_a_coordinate_vector_of_another_model_is_refused_before_a_kernel_reads_it(tmp_path):
    """The guard that makes the class of bug loud: q of the wrong length is a ValueError
    at the compiled kernels' entry and in the scene, never an out-of-bounds access."""
    from pipeline.kinematics.compiled import evaluate
    from pipeline.post.scene import posed_points
    from pipeline.workflow.outputs import machine_shapes

    m = build_machine(load_workflow(_write(tmp_path)), tmp_path / "links")
    mech = m.mechanism
    assert mech.n == 4
    with pytest.raises(ValueError, match=r"q has 1 entries; the mechanism has 4 coordinates"):
        evaluate(mech.compiled, np.zeros(1))
    with pytest.raises(ValueError, match=r"qd has 3 entries"):
        evaluate(mech.compiled, np.zeros(4), np.zeros(3))
    shape = machine_shapes(m)["bar"]
    with pytest.raises(ValueError, match="4 coordinates"):
        posed_points(mech, shape, np.zeros(1))
