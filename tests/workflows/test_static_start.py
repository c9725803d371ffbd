"""A dynamic run started from a static deflection under loads released at t = 0 (a pluck
test), against Euler-Bernoulli closed forms: the start is the cantilever's tip
deflection F L^3 / (3 EI), the release starts at rest, and the tip then swings about the
unloaded shape at the first bending frequency 1.8751^2 sqrt(EI / (rho A L^4))."""

from __future__ import annotations

import numpy as np
import pytest
from link_samples import beam_spec

from pipeline.core.errors import ConfigError
from pipeline.workflow import build_machine, load_workflow
from pipeline.workflow.analyses import run_analysis
from pipeline.workflow.series import marker_positions

L, E, RHO, A, IZ, F = 1.0, 2.1e11, 7850.0, 1e-4, 1e-8, 10.0

BAR = beam_spec("cantilever", L, A=A, Iy=4 * IZ, Iz=IZ, J=4 * IZ, E=E, rho=RHO,
                element_size=0.05, markers={"tip": L})

WORKFLOW = """\
name: pluck
gravity: [0, 0, 0]
links:
  ground: {type: ground, frames: {O: {origin: [0, 0, 0]}}}
  bar: {type: flexible, spec: bar.yaml, modes: 4, plane: xy}
joints:
  - {name: J, type: fixed, parent: ground.O, child: bar.root}
forces:
  - {name: push, type: point_force, marker: bar.tip, force: [0, -10.0, 0]}
analyses:
  - name: release
    type: dynamic
    t_end: 0.08
    outputs: 801
    rtol: 1.0e-9
    atol: 1.0e-12
    start: {loads: [push]}
"""


def _machine(tmp_path, text=WORKFLOW, sets=()):
    (tmp_path / "bar.yaml").write_text(BAR)
    p = tmp_path / "pluck.yaml"
    p.write_text(text)
    return build_machine(load_workflow(p, sets=list(sets)), tmp_path / "links")


def test_release_from_static_deflection_matches_beam_theory(tmp_path):
    m = _machine(tmp_path)
    r = run_analysis(m, "release")
    assert r.success and r.verdict == "ok", r.message
    tip = marker_positions(m.mechanism, r.q, "bar", "tip", elastic_only=True, axes="bar")[:, 1]
    ei = E * IZ
    delta = F * L ** 3 / (3 * ei)
    assert tip[0] == pytest.approx(-delta, rel=2e-3)  # 4 in-plane modes: truncation < 0.1 %
    assert np.abs(r.qd[0]).max() < 1e-9  # released at rest
    omega1 = 1.8751040687 ** 2 * np.sqrt(ei / (RHO * A * L ** 4))
    # the free swing about the unloaded shape: the first mode carries 97 % of a tip load's
    # static deflection, so the tip swings back to about +delta at the first frequency
    assert tip.max() == pytest.approx(delta, rel=0.06)
    spectrum = np.abs(np.fft.rfft(tip - tip.mean(), n=1 << 16))
    f = np.fft.rfftfreq(1 << 16, r.t[1] - r.t[0])
    k = int(np.argmax(spectrum))
    peak = f[k] + 0.5 * (f[1] - f[0]) * (spectrum[k - 1] - spectrum[k + 1]) / (
        spectrum[k - 1] - 2 * spectrum[k] + spectrum[k + 1])
    assert 2 * np.pi * peak == pytest.approx(omega1, rel=1e-2)
    # the released load does no work in the run: elastic + kinetic energy stays the
    # strain energy of the start, F delta / 2
    total = r.energies["kinetic"] + r.energies["elastic"]
    assert total == pytest.approx(np.full_like(total, 0.5 * F * delta), rel=5e-3)


def test_static_start_keeps_the_loads_without_release(tmp_path):
    """`start: static` keeps every force: the start is already the equilibrium, so the
    bar stays put."""
    m = _machine(tmp_path, sets=["analyses.release.start=static"])
    r = run_analysis(m, "release")
    tip = marker_positions(m.mechanism, r.q, "bar", "tip", elastic_only=True, axes="bar")[:, 1]
    assert np.ptp(tip) < 1e-6 * abs(tip[0])


def test_unknown_released_load_is_named(tmp_path):
    m = _machine(tmp_path, WORKFLOW.replace("loads: [push]", "loads: [pull]"))
    with pytest.raises(ConfigError, match=r"pluck.yaml:17: analyses\[0\]\.start\.loads\[0\].*'pull'.*push"):
        run_analysis(m, "release")
