"""Frequency convergence of a reduction (issue 24, item 1): the estimate from a mesh twice
as coarse against the true discretisation error of a cantilever, known in closed form."""

from __future__ import annotations

import numpy as np
import pytest
from link_samples import beam_spec

from pipeline.invariants.adequacy import frequency_convergence, mesh_warnings
from pipeline.workflow.link_build import reduce_spec
from pipeline.workflow.link_spec import load_link_spec

L, E, RHO, A, I = 1.0, 2.1e11, 7850.0, 1e-2, 1e-10  # radius of gyration 1e-4 L: no shear, rotary inertia below 1e-6
BETA_L = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])


def _frequencies(tmp_path, size):
    path = tmp_path / f"cant{size}.yaml"
    path.write_text(beam_spec("cant", L, A=A, Iy=1e4 * I, Iz=I, J=2e4 * I, element_size=size,
                              E=E, rho=RHO, modes="{count: 4}"))
    link, _ = reduce_spec(load_link_spec(path), tmp_path, tmp_path / f"links{size}")
    return link.frequencies_hz


def test_the_estimated_error_is_the_true_one_on_a_cantilever(tmp_path):
    """Hermite beams of 16 and 8 elements: the four lowest bending frequencies about the
    soft axis (Iy is 1e4 times Iz, so they come first) are off the Euler-Bernoulli values
    by up to 1.4e-4; Richardson's estimate from the 8-element mesh (rate 4) matches each
    to 25 %. (Where the coarse mesh does not resolve a mode it says too little: the fourth
    mode on 8 elements is 2.2e-3 off, estimated 8e-4 from 4 elements.)"""
    exact = BETA_L ** 2 / (2 * np.pi * L ** 2) * np.sqrt(E * I / (RHO * A))
    fine, coarse = _frequencies(tmp_path, L / 16), _frequencies(tmp_path, L / 8)
    rows = frequency_convergence(fine, coarse, rate=4)
    true = (fine - exact) / exact
    for r, t in zip(rows, true, strict=True):
        if abs(t) > 1e-6:  # above the eigen solver's round-off
            assert r["error"] == pytest.approx(t, rel=0.25), (r, t)
    assert true[3] > 1e-4  # the fourth mode is measurably off on 16 elements
    (line,) = mesh_warnings("cant", [dict(r, error=100 * r["error"]) for r in rows],
                            "geometry.element_size")
    assert "mode 3" in line and "refine geometry.element_size" in line
    assert mesh_warnings("cant", rows, "geometry.element_size") == []
