"""Effective masses against the Euler-Bernoulli cantilever (closed-form shapes, quadrature),
the rigid totals against m L^2 / 3, the aligned basis of a round section (Iy = Iz: the
plane filter used to find one in-plane mode of three), and the mode rules of a workflow
keeping the same physical modes on a coarse and a fine mesh."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from link_samples import beam_spec

from pipeline.core.errors import ConfigError
from pipeline.invariants.participation import (
    effective_mass_fractions,
    participation,
    rigid_totals,
    transform_modes,
)
from pipeline.workflow.build import kept_modes
from pipeline.workflow.link_build import reduce_spec
from pipeline.workflow.link_spec import LinkSpec, load_link_spec
from pipeline.workflow.overrides import apply_overrides
from pipeline.workflow.schema import ModeSelection
from pipeline.workflow.yaml_io import load_yaml

pytestmark = pytest.mark.gmsh

L, E, RHO, A, IZ = 1.0, 2.1e11, 7850.0, 1e-4, 1e-10  # r_g = 1 mm: rotary inertia ~1e-4
EB_ROOTS = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613,
                     10.99554073487547])


def _bar(folder: Path, iy: float, size: float = 0.05, count: int = 12):
    spec = folder / f"bar_{iy:g}_{size:g}.yaml"
    spec.write_text(beam_spec("bar", L, A=A, Iy=iy, Iz=IZ, J=2 * IZ, E=E, rho=RHO,
                              element_size=size, interfaces=("root", "tip"),
                              modes=f"{{count: {count}}}"))
    return reduce_spec(load_link_spec(spec), folder, folder / f"links_{size:g}")[0]


def _eb_fractions() -> np.ndarray:
    """(int phi dx)^2 / (L int phi^2 dx) of the closed-form clamped-free shapes."""
    xg, wg = np.polynomial.legendre.leggauss(200)
    x, w = 0.5 * L * (xg + 1), 0.5 * L * wg
    out = []
    for b in EB_ROOTS / L:
        s = (np.cosh(b * L) + np.cos(b * L)) / (np.sinh(b * L) + np.sin(b * L))
        phi = np.cosh(b * x) - np.cos(b * x) - s * (np.sinh(b * x) - np.sin(b * x))
        out.append((w @ phi) ** 2 / (L * (w @ phi ** 2)))
    return np.array(out)


def test_cantilever_effective_masses_are_euler_bernoulli(tmp_path):
    link = _bar(tmp_path, 4 * IZ)
    frac = effective_mass_fractions(link)
    y_modes = [a for a in range(link.n_modes) if frac[a, 1] > 1e-3][:4]
    np.testing.assert_allclose(frac[y_modes, 1], _eb_fractions(), rtol=2e-3)
    # over every mode of the clamped model the translational effective masses sum to the
    # link's mass less the share of the clamped root node (about half an element's)
    every = effective_mass_fractions(_bar(tmp_path, 4 * IZ, count=114))
    assert 1 - 0.05 / L < every[:, 1].sum() < 1 - 0.01 / L
    assert 1 - 0.05 / L < every[:, 0].sum() < 1 - 0.01 / L  # axial too
    # rigid totals: the mass three times, rotations m L^2 / 3 about the root (bar axis ~0)
    m = RHO * A * L
    tot = rigid_totals(link)
    np.testing.assert_allclose(tot[:3], m, rtol=1e-12)
    np.testing.assert_allclose(tot[4:], m * L ** 2 / 3, rtol=1e-3)
    # at the tip interface the bending modes' rotational participation changes sign
    # (r - p) x phi with p = (L, 0, 0): int rho (x - L) phi_y dx < 0 for the first mode
    a = y_modes[0]
    assert participation(link, "tip")[a, 5] < 0 < participation(link)[a, 5]


def test_round_section_keeps_its_in_plane_modes(tmp_path):
    """Iy = Iz: each bending frequency is repeated; the eigen solver returns mixtures of
    the two planes, and `plane: xy` found 1 of 3 requested in-plane modes (as reported).
    The reduction now completes a pair the count would split and rotates each pair onto
    the body axes."""
    link = _bar(tmp_path, IZ, count=7)
    assert link.n_modes == 8  # 7 asked; the 7th's partner completes the pair
    assert link.meta["modal_basis"]["aligned_clusters"][:3] == [[0, 1], [2, 3], [4, 5]]
    xy = kept_modes(link, 3, "xy")
    assert xy == (0, 2, 4)
    tip = link.frame("tip").phi
    assert np.abs(tip[list(xy), 2]).max() < 1e-9 * np.abs(tip[list(xy), 1]).max()
    # the aligned basis is still mass-normalised, with the same stiffness spectrum
    np.testing.assert_allclose(link.modal_mass, np.eye(8), atol=1e-9)
    np.testing.assert_allclose(np.sort(np.linalg.eigvalsh(link.modal_stiffness)),
                               np.sort((2 * np.pi * link.frequencies_hz) ** 2), rtol=1e-9)


def test_transform_modes_transforms_every_invariant(tmp_path):
    link = _bar(tmp_path, 4 * IZ, count=5)
    Q, _ = np.linalg.qr(np.random.default_rng(1).standard_normal((5, 5)))
    new = transform_modes(link, Q)
    np.testing.assert_allclose(np.linalg.eigvalsh(new.modal_stiffness),
                               np.linalg.eigvalsh(link.modal_stiffness), rtol=1e-10)
    # participation transforms with the modes; tr C''_aa is the modal mass
    T = np.linalg.lstsq(link.mode_shapes.reshape(5, -1).T, new.mode_shapes.reshape(5, -1).T,
                        rcond=None)[0]  # the Q actually applied (signs included)
    np.testing.assert_allclose(participation(new), T.T @ participation(link), atol=1e-12)
    np.testing.assert_allclose(np.einsum("aaii->a", new.Cpp), np.diag(new.modal_mass),
                               rtol=1e-10)


def test_effective_mass_rule_keeps_the_same_modes_on_coarse_and_fine_meshes(tmp_path):
    """`modes: {effective_mass: 0.85, directions: [ty]}` keeps the three lowest y-bending
    modes (61 + 19 + 6.5 %) on a 5-element and a 50-element mesh of a round bar."""
    rule = ModeSelection(effective_mass=0.85, directions=["ty"])
    picks = []
    for size in (0.2, 0.02):
        link = _bar(tmp_path, IZ, size=size, count=10)
        idx = kept_modes(link, rule, "xy")
        frac = effective_mass_fractions(link)[list(idx)]
        picks.append((idx, link.frequencies_hz[list(idx)], frac[:, 1]))
    (a, fa, ma), (b, fb, mb) = picks
    assert a == b and len(a) == 3
    np.testing.assert_allclose(fa, fb, rtol=5e-3)
    np.testing.assert_allclose(ma, mb, rtol=5e-3)
    assert 0.85 <= mb.sum() < 0.88
    with pytest.raises(ConfigError, match=r"0.999 not reached .*\(ty 0\.\d+\)"):
        kept_modes(link, ModeSelection(effective_mass=0.999, directions=["ty"]), "xy")
    assert kept_modes(link, ModeSelection(f_max=3.0), None) == (0, 1)  # the 2.9 Hz pair


@pytest.mark.slow  # the full lift arm reduction (17 s)
def test_plane_filter_keeps_the_same_modes_on_the_quick_and_full_lift_arm(tmp_path):
    """The lift arm's Craig-Bampton basis (4 pins besides the reference: 12 in-plane
    constraint modes; its 6 fixed-interface modes are all out of the plate's plane) has
    12 in-plane modes on any mesh. On the quick mesh (one element through the 25 mm
    plate, not symmetric about its mid-plane) the 68 Hz in-plane mode lies 0.4 % below an
    out-of-plane one and takes 2 % of its frame motion from it: the frame test dropped it
    (and the 1.2 kHz one), so the quick and full runs kept different modes."""
    spec = Path(__file__).resolve().parents[2] / "meshes" / "lift_arm.yaml"
    found = []
    for size in (0.03, 0.02):
        data = apply_overrides(load_yaml(spec)[0], {"geometry.mesh_size": size,
                                                    "modes.count": 6,
                                                    "modes.craig_bampton": True}, "test")
        link = reduce_spec(LinkSpec.model_validate(data), spec.parent,
                           tmp_path / f"links_{size:g}")[0]
        idx = kept_modes(link, None, "xy")
        assert len(idx) == 12, (size, link.frequencies_hz[list(idx)])
        found.append(link.frequencies_hz[list(idx)])
    np.testing.assert_allclose(found[0], found[1], rtol=2e-2)
