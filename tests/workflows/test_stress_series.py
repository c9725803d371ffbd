"""Stress histories through a workflow: a cantilever beam link with a tip load, reduced
with the tip's Craig-Bampton constraint modes (which span the static response exactly):
the static section moment is F (L - x) at the root, mid-span and tip markers, and the
series is written in the plot units (kN m here, MPa for solid stresses)."""

from __future__ import annotations

import numpy as np
import pytest
from link_samples import beam_spec

from pipeline.core.errors import ConfigError
from pipeline.workflow import build_machine, load_workflow
from pipeline.workflow.analyses import run_analysis
from pipeline.workflow.series import check_series, series

pytestmark = pytest.mark.gmsh

L, F = 2.0, 1500.0

BAR = beam_spec("cantilever", L, A=1.0e-3, Iy=4.0e-7, Iz=1.0e-7, J=4.0e-7, element_size=0.1,
                interfaces=("root", "tip"), markers={"mid": L / 2},
                modes="{count: 4, craig_bampton: true}")

WORKFLOW = f"""\
name: loaded
gravity: [0, 0, 0]
links:
  ground: {{type: ground, frames: {{O: {{origin: [0, 0, 0]}}}}}}
  bar: {{type: flexible, spec: bar.yaml}}
joints:
  - {{name: J, type: fixed, parent: ground.O, child: bar.root}}
forces:
  - {{name: load, type: point_force, marker: bar.tip, force: [0, -{F}, 0]}}
analyses:
  - name: sag
    type: static
"""


@pytest.fixture(scope="module")
def loaded(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stress")
    (folder / "bar.yaml").write_text(BAR)
    (folder / "loaded.yaml").write_text(WORKFLOW)
    m = build_machine(load_workflow(folder / "loaded.yaml"), folder / "links")
    return m, run_analysis(m, "sag")


@pytest.mark.parametrize(("frame", "x"), [("root", 0.0), ("mid", L / 2), ("tip", L)])
def test_section_moment_is_f_times_arm(loaded, frame, x):
    m, r = loaded
    assert r.success
    mz = series(r, m.mechanism, f"stress:bar.{frame}:Mz", m.parts)
    assert mz.unit == "N m"
    assert mz.values[0] == pytest.approx(-F * (L - x), abs=1e-6 * F * L)
    vy = series(r, m.mechanism, f"stress:bar.{frame}:Vy", m.parts)
    assert vy.values[0] == pytest.approx(F, rel=1e-6)  # dMz/ds
    n = series(r, m.mechanism, f"stress:bar.{frame}:N", m.parts)
    assert abs(n.values[0]) < 1e-6 * F


def test_stress_series_errors_name_what_exists(loaded):
    m, _ = loaded
    with pytest.raises(ConfigError, match=r"quantity 'von_mises'.*\['N', 'Vy'"):
        check_series("stress:bar.root:von_mises", m.mechanism, "static", m.parts)
    with pytest.raises(ConfigError, match=r"frame 'elbow' is not on link 'bar'"):
        check_series("stress:bar.elbow:Mz", m.mechanism, "static", m.parts)
    with pytest.raises(ConfigError, match=r"flexible link of \['bar'\]"):
        check_series("stress:ground.O:Mz", m.mechanism, "static", m.parts)
    assert np.isfinite(series(loaded[1], m.mechanism, "stress:bar.tip:Mz", m.parts).values).all()


def test_a_case_without_modes_has_no_stress(tmp_path):
    """links.bar.modes=0: the link is rigid, its stress is unknown -- NaN, in the same unit
    as the flexible case's (a moment in N m)."""
    (tmp_path / "bar.yaml").write_text(BAR)
    (tmp_path / "loaded.yaml").write_text(WORKFLOW)
    m = build_machine(load_workflow(tmp_path / "loaded.yaml", sets=["links.bar.modes=0"]),
                      tmp_path / "links")
    r = run_analysis(m, "sag")
    mz = series(r, m.mechanism, "stress:bar.root:Mz", m.parts)
    assert mz.unit == "N m" and np.isnan(mz.values).all() and "rigid case" in mz.label


def test_a_resultant_no_kept_mode_carries_is_not_reported_as_zero(tmp_path):
    """The bar with two bending modes in its xy plane and no constraint modes: they carry
    no axial force, so its series would read zero whatever pulled the bar (a pinned rod's
    axial force without its axial mode) -- NaN, saying why; the bending moment is there."""
    (tmp_path / "bar.yaml").write_text(BAR.replace("{count: 4, craig_bampton: true}",
                                                   "{count: 4}"))
    (tmp_path / "loaded.yaml").write_text(WORKFLOW.replace(
        "{type: flexible, spec: bar.yaml}", "{type: flexible, spec: bar.yaml, modes: 2, "
                                            "plane: xy}"))
    m = build_machine(load_workflow(tmp_path / "loaded.yaml"), tmp_path / "links")
    r = run_analysis(m, "sag")
    n = series(r, m.mechanism, "stress:bar.root:N", m.parts)
    assert np.isnan(n.values).all() and "none of the kept modes carries it" in n.label
    mz = series(r, m.mechanism, "stress:bar.root:Mz", m.parts)
    assert np.isfinite(mz.values).all() and abs(mz.values[0]) > 0.5 * F * L
