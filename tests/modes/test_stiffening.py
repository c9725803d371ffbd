"""RBE3 adds no stiffness, RBE2 does: free-free frequencies with and without them."""

import numpy as np
import pytest
from conftest import box_model

from pipeline.fem.interfaces import make_interface, tie_interfaces
from pipeline.modes import lowest_modes

L, B, H = 0.2, 0.04, 0.02
SIGMA = -(2 * np.pi * 5.0) ** 2  # below the six rigid modes at 0


@pytest.fixture(scope="module")
def plate():
    return box_model(L, B, H, 20, 4, 2, name="plate")


def _bore(model, centre, radius):
    """Nodes within ``radius`` of the z-axis line through ``centre`` (a pin region)."""
    d = np.linalg.norm(model.nodes[:, :2] - centre, axis=1)
    return np.flatnonzero(d <= radius + 1e-12)


def _free_free_hz(tied, k=12):
    lam, _ = lowest_modes(tied.stiffness, tied.mass, k, sigma=SIGMA, where="free-free")
    return np.sign(lam) * np.sqrt(np.abs(lam)) / (2 * np.pi)


def test_rbe3_does_not_stiffen_and_rbe2_does(plate):
    end = np.flatnonzero(np.isclose(plate.nodes[:, 0], 0.0))
    bore = _bore(plate, [0.12, B / 2], 0.011)
    assert bore.size > 20
    base = [make_interface(plate, "end", [0, B / 2, H / 2], None, "rbe2", end)]
    with_rbe3 = base + [make_interface(plate, "pin", [0.12, B / 2, H / 2], None, "rbe3", bore)]
    with_rbe2 = base + [make_interface(plate, "pin", [0.12, B / 2, H / 2], None, "rbe2", bore)]
    f_base = _free_free_hz(tie_interfaces(plate, base))
    f_rbe3 = _free_free_hz(tie_interfaces(plate, with_rbe3))
    f_rbe2 = _free_free_hz(tie_interfaces(plate, with_rbe2))
    # six rigid modes in each case (|f| tiny against the first elastic one)
    for f in (f_base, f_rbe3, f_rbe2):
        assert np.all(np.abs(f[:6]) < 1e-4 * f[6])
    np.testing.assert_allclose(f_rbe3[6:], f_base[6:], rtol=1e-10)
    rise = f_rbe2[6:] / f_base[6:] - 1
    print("\nfree-free elastic frequencies (Hz):", f_base[6:], "\nRBE2 pin raises them by", rise)
    assert np.all(rise > -1e-10) and rise.max() > 0.05


def test_rbe3_only_model_keeps_its_matrices(plate):
    bore = _bore(plate, [0.12, B / 2], 0.011)
    tied = tie_interfaces(plate, [make_interface(plate, "pin", [0.12, B / 2, 0], None, "rbe3",
                                                 bore)])
    f0 = _free_free_hz(tie_interfaces(plate, []))
    np.testing.assert_array_equal(_free_free_hz(tied), f0)
