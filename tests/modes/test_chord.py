"""Chord reference conditions (modes.chord): a link pinned at both ends whose body frame
follows the line through its pins. Against Euler-Bernoulli's pinned-pinned frequencies
(beam and P2 solid), the far interface moving along the chord only, and the errors."""

from __future__ import annotations

import numpy as np
import pytest
from link_samples import beam_spec

from pipeline.core.errors import ConfigError
from pipeline.fem.interfaces import make_interface, tie_interfaces
from pipeline.modes import clamped_modes
from pipeline.workflow.link_build import reduce_spec
from pipeline.workflow.link_spec import load_link_spec

L, A, IZ, E, RHO = 1.0, 1e-4, 1e-9, 2.1e11, 7850.0


def _pinned_pinned_hz(n: int, EI: float, mu: float, length: float) -> float:
    return (n * np.pi / length) ** 2 * np.sqrt(EI / mu) / (2 * np.pi)


def test_beam_chord_modes_are_the_pinned_pinned_modes(tmp_path):
    spec = tmp_path / "rod.yaml"
    spec.write_text(beam_spec("rod", L, A=A, Iy=4 * IZ, Iz=IZ, J=4 * IZ, E=E, rho=RHO,
                              element_size=0.025, ends=("A", "B"), interfaces=("A", "B"),
                              modes="{count: 6, chord: B}"))
    link = reduce_spec(load_link_spec(spec), tmp_path, tmp_path / "links")[0]
    f = link.frequencies_hz
    mu = RHO * A
    # y bending (Iz) n = 1, z bending (Iy = 4 Iz) n = 1, y n = 2
    for got, want in zip(f[:3], (_pinned_pinned_hz(1, E * IZ, mu, L),
                                 _pinned_pinned_hz(1, 4 * E * IZ, mu, L),
                                 _pinned_pinned_hz(2, E * IZ, mu, L))):
        assert got == pytest.approx(want, rel=1e-3)
    a, b = link.frame("A"), link.frame("B")
    assert np.abs(a.phi).max() == 0.0  # the reference is held in translation
    assert np.abs(b.phi[:, 1:]).max() < 1e-12 * np.abs(b.phi).max()  # B: along the chord
    assert np.abs(a.psi[:, 0]).max() < 1e-12 * np.abs(a.psi).max()  # no twist about it
    assert np.abs(a.psi).max() > 0  # but the pinned end turns
    assert link.meta["reference_conditions"] == {"reference": "A", "chord": "B",
                                                 "craig_bampton": []}


def test_p2_bar_chord_modes_bend_like_a_pinned_pinned_beam(bar):
    """The skfem P2 bar (0.4 x 0.02 x 0.01 m) with rigid end faces tied to master points
    on the centre line: its first (weak-axis) chord mode within 2 % of Euler-Bernoulli."""
    length, b, h = 0.4, 0.02, 0.01
    faces = [np.flatnonzero(np.isclose(bar.nodes[:, 0], x)) for x in (0.0, length)]
    itfs = [make_interface(bar, n, [x, b / 2, h / 2], None, "rbe2", f)
            for n, x, f in zip(("A", "B"), (0.0, length), faces)]
    basis = clamped_modes(tie_interfaces(bar, itfs), "A", n_modes=3, chord="B")
    mu, EI = 7850.0 * b * h, 210e9 * b * h ** 3 / 12
    assert basis.frequencies_hz[0] == pytest.approx(_pinned_pinned_hz(1, EI, mu, length),
                                                    rel=2e-2)
    assert basis.settings["chord"] == "B"


def test_chord_errors(bar):
    length = 0.4
    faces = [np.flatnonzero(np.isclose(bar.nodes[:, 0], x)) for x in (0.0, length)]
    itfs = [make_interface(bar, n, [x, 0.01, 0.005], None, "rbe2", f)
            for n, x, f in zip(("A", "B"), (0.0, length), faces)]
    tied = tie_interfaces(bar, itfs)
    with pytest.raises(ConfigError, match="exclude each other"):
        clamped_modes(tied, "A", n_modes=2, craig_bampton=True, chord="B")
    with pytest.raises(ConfigError, match="an interface away from the reference"):
        clamped_modes(tied, "A", n_modes=2, chord="A")
    with pytest.raises(ConfigError, match="'C'"):
        clamped_modes(tied, "A", n_modes=2, chord="C")


def test_python_api_link_has_the_chord_frame_and_second_order_translations(tmp_path):
    """link_from_reduced (the Python API) builds a chord link's frames as a workflow does:
    the reference's frame does not turn with the end, and with ``second_order`` each
    frame's translation carries -K_F of the unit force cases."""
    from pipeline.dynamics import link_from_reduced

    spec = tmp_path / "rod.yaml"
    spec.write_text(beam_spec("rod", L, A=A, Iy=4 * IZ, Iz=IZ, J=4 * IZ, E=E, rho=RHO,
                              element_size=0.025, ends=("A", "B"), interfaces=("A", "B"),
                              modes="{count: 4, chord: B, geometric_stiffening: true}"))
    red = reduce_spec(load_link_spec(spec), tmp_path, tmp_path / "links")[0]
    link = link_from_reduced(red, [0, 2], second_order=True)
    assert np.abs(link.frame("A").psi).max() == 0.0
    assert np.abs(red.frame("A").psi).max() > 0  # the end itself turns
    KF = red.force_geometric_stiffness[1][:, [0, 2]][:, :, [0, 2]]  # frame B
    np.testing.assert_array_equal(link.frame("B").hess, -np.transpose(KF, (1, 2, 0)))
    assert link.frame("B").hess[0, 0, 0] < 0  # bending shortens the chord
    assert link_from_reduced(red, [0, 2]).frame("B").hess is None
