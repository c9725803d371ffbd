"""Clamped modes computed by another FE code as a link's basis (issue 28 item 2: "where
given, mode shapes and stress modes"): CalculiX's own modes of the cantilever box, read
from its .frd result file, against the reduction's own eigen solve on the same mesh and
against CalculiX's frequencies.

The .frd prints 6 significant digits, so the imported shapes (and every invariant made
from them) agree with the native ones to ~1e-5; their frequencies are Rayleigh quotients
on the link's own K and M, second order in that error.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from calculix_box import PLANES, calculix_deck, make_box, run_calculix, write_spec

from pipeline.core.errors import ConfigError

pytestmark = pytest.mark.skipif(shutil.which("ccx") is None,
                                reason="CalculiX (apt calculix-ccx) absent")
OUTPUTS = "*NODE FILE\nU\n*EL FILE\nS\n*END STEP"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """CalculiX's clamped modes of the box (.frd with shapes and stresses, 8 modes), its
    free-free K and M, and the native reduction of the same mesh (6 modes)."""
    from pipeline.workflow.link_build import reduce_spec

    tmp = tmp_path_factory.mktemp("external")
    box = make_box()
    run_calculix(tmp / "ccx", calculix_deck(box, n=8).replace("*END STEP", OUTPUTS))
    run_calculix(tmp / "free", calculix_deck(box, clamped=False, storage=True), "model")
    native, _ = reduce_spec(write_spec(tmp, "ccx/box.inp", "mm", PLANES), tmp, tmp / "out")
    return tmp, native


def _link(tmp: Path, modes: str, extra: str = "", mesh: str = "ccx/box.inp"):
    from pipeline.workflow.link_build import reduce_spec

    spec = write_spec(tmp, mesh, "mm", PLANES, extra=extra, modes=modes)
    return reduce_spec(spec, tmp, tmp / "out")[0]


def _frd_frequencies(tmp: Path) -> np.ndarray:
    from pipeline.modes.external import read_frd

    return read_frd(tmp / "ccx" / "box.frd").frequencies_hz


def test_calculix_modes_give_the_native_link(runs):
    tmp, native = runs
    link = _link(tmp, "{count: 6, file: ccx/box.frd}")
    ours, theirs = np.asarray(native.frequencies_hz), _frd_frequencies(tmp)[:6]
    got = np.asarray(link.frequencies_hz)
    # the file's frequencies (its stiffness), within the two codes' 3e-5 of the native
    assert np.allclose(got, theirs, rtol=1e-8), (got, theirs)
    assert np.allclose(got, ours, rtol=3e-5)
    # the file's eigenvalues; coupled only by the orthonormalisation of printed shapes
    K = link.modal_stiffness
    assert np.allclose(np.diag(K), (2 * np.pi * theirs) ** 2, rtol=1e-8)
    assert np.abs(K - np.diag(np.diag(K))).max() < 1e-5 * K.max()
    # the invariants and frames made from the imported shapes: the native ones to ~1e-5
    scale = np.abs(native.Cp).max()
    print("C' and C'' differences:", np.abs(link.Cp - native.Cp).max() / scale,
          np.abs(link.Cpp - native.Cpp).max() / np.abs(native.Cpp).max())
    assert np.abs(link.Cp - native.Cp).max() < 2e-5 * scale
    assert np.abs(link.Cpp - native.Cpp).max() < 2e-5 * np.abs(native.Cpp).max()
    assert np.allclose(link.modal_mass, np.eye(6), atol=1e-12)
    tip = next(f for f in link.frames if f.name == "tip")
    tip0 = next(f for f in native.frames if f.name == "tip")
    assert np.abs(tip.phi - tip0.phi).max() < 2e-5 * np.abs(tip0.phi).max()
    assert np.abs(link.mode_shapes - native.mode_shapes).max() < \
        2e-5 * np.abs(native.mode_shapes).max()
    assert link.meta["modes_file"]["largest_frequency_deviation"] < 3e-5
    # f_max selects from the file like from a solve
    assert _link(tmp, "{f_max: 400.0, file: ccx/box.frd}").frequencies_hz.size == 3


def test_matrices_with_calculix_modes_carry_calculix_stresses(runs):
    """The link imported as CalculiX's matrices has no element formulation: its stress
    modes are CalculiX's nodal stresses of its modes. Against the native recovery on the
    same mesh (P2 stress at the element nodes, mean over the elements: the same rule as
    CalculiX's extrapolation from the integration points of straight C3D10s)."""
    tmp, native = runs
    link = _link(tmp, "{count: 6, file: ccx/box.frd}",
                 extra=", matrices: {format: calculix, stiffness: free/model.sti, mass: "
                       "free/model.mas, dofs: free/model.dof, mass_unit: t}",
                 mesh="free/model.inp")
    assert "box.frd" in link.meta["stress"]["recovery"]
    S, S0 = link.stress_modes, native.stress_modes
    assert S.shape == S0.shape
    print("stress modes, largest difference / largest stress:",
          np.abs(S - S0).max() / np.abs(S0).max())
    assert np.abs(S - S0).max() < 5e-4 * np.abs(S0).max()
    assert np.allclose(link.frequencies_hz, _frd_frequencies(tmp)[:6], rtol=1e-8)


def test_a_mode_file_that_is_not_this_links_is_refused(runs, tmp_path):
    tmp, _ = runs
    frd = (tmp / "ccx" / "box.frd").read_text()
    # too few modes
    with pytest.raises(ConfigError, match=r"modes\.file: box\.frd: has 8 modes, modes\.count "
                                          r"asks for 9"):
        _link(tmp, "{count: 9, file: ccx/box.frd}")
    # another material: the Rayleigh quotients miss the file's frequencies
    stiff = tmp / "stiff"
    stiff.mkdir(exist_ok=True)
    (stiff / "box.frd").write_text(frd)
    with pytest.raises(ConfigError, match=r"mode 1 is 52\.6\d* Hz in the file but 37\.\d+ Hz "
                                          r"on this link's own K and M"):
        from pipeline.workflow.link_build import reduce_spec

        spec = write_spec(tmp, "ccx/box.inp", "mm", PLANES,
                          modes="{count: 6, file: stiff/box.frd}")
        reduce_spec(spec.model_copy(update={"material": spec.material.model_copy(
            update={"E": spec.material.E / 2})}), tmp, tmp / "out")
    # a free (unclamped) model's modes move the reference
    run_calculix(tmp_path / "free", calculix_deck(make_box(), clamped=False, n=10)
                 .replace("*END STEP", OUTPUTS))
    with pytest.raises(ConfigError, match="moves the reference interface 'pivot'"):
        _link(tmp, "{count: 6, file: " + str(tmp_path / "free" / "box.frd") + "}")
    # the coordinates of another mesh
    (tmp / "moved.frd").write_text(frd.replace(" 0.00000E+00 0.00000E+00 0.00000E+00",
                                               " 5.00000E+00 0.00000E+00 0.00000E+00", 1))
    with pytest.raises(ConfigError, match="node coordinates are up to 0.005 m off"):
        _link(tmp, "{count: 6, file: moved.frd}")
    with pytest.raises(ConfigError, match=r"box\.yaml:\d+: modes: file: .*need its input as "
                                          r"the mesh"):
        write_spec(tmp, "model.bdf", "mm", PLANES, modes="{count: 6, file: ccx/box.frd}")
