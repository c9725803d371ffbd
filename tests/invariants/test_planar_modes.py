"""Per-mode planes of a link's frame motion and the round-off across them
(pipeline.invariants.planar_modes)."""

import numpy as np
import pytest

from pipeline.invariants.planar_modes import PLANE_RTOL, mode_planes, without_plane_round_off


def _frames(across: float, rng=np.random.default_rng(3)):
    """Two frames, three modes: in x-y with ``across`` of out-of-plane motion, axial (x
    only), and a spatial one."""
    phi = np.zeros((2, 3, 3))
    psi = np.zeros((2, 3, 3))
    phi[:, 0] = [[0.1, 1.0, 0.0], [0.0, 0.5, 0.0]]
    psi[:, 0, 2] = [0.8, 0.3]
    phi[:, 0, 2] = across * np.array([1.0, -0.5])
    psi[:, 0, 0] = across * 0.3
    phi[:, 1, 0] = [1.0, 2.0]
    phi[:, 2] = rng.normal(size=(2, 3))
    psi[:, 2] = rng.normal(size=(2, 3))
    return phi, psi


@pytest.mark.parametrize("share, planar", [(0.0, True), (1e-6, True), (0.9 * PLANE_RTOL, True),
                                          (1.1 * PLANE_RTOL, False), (1e-1, False)])
def test_a_mode_is_in_a_plane_up_to_the_round_off_share(share, planar):
    phi, psi = _frames(share)
    planes = mode_planes(phi, psi, length=1.0)
    assert planes[0] == (("xy",) if planar else ())
    assert planes[1] == ("xy", "xz")  # axial: in both planes it lies in
    assert planes[2] == ()
    for f in range(2):
        p, r = without_plane_round_off(phi[f], psi[f], planes)
        if planar:
            assert p[0, 2] == 0.0 and r[0, 0] == 0.0 and r[0, 1] == 0.0
        np.testing.assert_array_equal(p[0, :2], phi[f, 0, :2])  # the plane's motion stays
        np.testing.assert_array_equal(r[0, 2], psi[f, 0, 2])
        np.testing.assert_array_equal(p[2], phi[f, 2])  # a spatial mode keeps everything
        np.testing.assert_array_equal(r[2], psi[f, 2])
        assert not np.any(p[1, 1:]) and not np.any(r[1])


def test_rotations_count_by_the_link_length():
    """A frame turned out of the plane by 2e-4 rad: on a 20 m link that is 4e-3 m against
    2 m in the plane (above PLANE_RTOL), on a 1 m link 2e-4 m against 1 m (within)."""
    phi = np.array([[[0.0, 1.0, 0.0]]])
    psi = np.array([[[2e-4, 0.0, 0.1]]])
    assert mode_planes(phi, psi, length=20.0) == ((),)
    assert mode_planes(phi, psi, length=1.0) == (("xy",),)
    assert mode_planes(np.zeros((1, 1, 3)), np.zeros((1, 1, 3)), 1.0) == ((),)
