"""Camera directions: any finite, non-zero [x, y, z] is a direction, however large its
entries (the fuzzer's 1e308 overflowed the norm: a RuntimeWarning on the user's terminal
and a direction of length inf accepted, then drawn as zeros)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pipeline.core.errors import ConfigError
from pipeline.post.views import check_camera, view_direction


def test_a_huge_direction_is_a_direction_and_warns_nothing():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_camera([1e308, -1e308, 0.0]) == [1e308, -1e308, 0.0]
        np.testing.assert_allclose(view_direction([1e308, -1e308, 0.0]),
                                   [2 ** -0.5, -(2 ** -0.5), 0.0])
        np.testing.assert_allclose(view_direction([0.0, 0.0, 5e-320]), [0.0, 0.0, 1.0])


@pytest.mark.parametrize("camera", [[0, 0, 0], [np.inf, 0, 0], [np.nan, 1, 0], [1, 2],
                                    "top"])
def test_what_is_no_direction_is_refused(camera):
    with pytest.raises(ConfigError, match="expected a named view"):
        check_camera(camera)


@pytest.mark.render
@pytest.mark.parametrize("up", [(0, 0, 1), (0, 1, 0), (0, -1, 0), (1, 0, 0),
                                (0.3, 0.9, 0.1)])
@pytest.mark.parametrize("camera", ["iso", [2.0, 1.0, 0.5]])
def test_the_vertical_stands_upright_on_the_screen(up, camera):
    """Issue 29: iso views of y-up machines were drawn on their side (pyvista's isometric
    view keeps z up). With ``up`` against gravity, the world's up is the screen's up (no
    sideways component in camera axes, pointing up), and iso looks down on the machine."""
    pv = pytest.importorskip("pyvista")
    from pipeline.post.scene import _camera, view_setting

    u = np.asarray(up, dtype=float) / np.linalg.norm(up)
    plotter = pv.Plotter(off_screen=True, window_size=(200, 150))
    try:
        plotter.add_mesh(pv.Sphere())
        _camera(plotter, camera, tuple(u))
        view = plotter.camera.GetViewTransformMatrix()
        R = np.array([[view.GetElement(i, j) for j in range(3)] for i in range(3)])
    finally:
        plotter.close()
    on_screen = R @ u  # camera axes: x right, y up, z towards the viewer
    v, _ = view_setting(camera, tuple(u))
    if abs(v @ u) < 0.9:
        assert abs(on_screen[0]) < 1e-9 and on_screen[1] > 0.4
    if camera == "iso":
        assert v @ u == pytest.approx(np.sqrt(1 / 3))  # 35.26 deg above the horizontal
