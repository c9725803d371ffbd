"""Camera views of renders and animations: the named views, and what a direction must be.

Checked where a workflow is read (its schema) and where a scene is drawn (the Python API),
by the same rule.
"""

from __future__ import annotations

import numpy as np

from pipeline.core.errors import ConfigError

#: named views: along -z, -y, -x onto the plane named (parallel projection), or isometric
CAMERAS = ("xy", "xz", "yz", "iso")


def check_camera(camera):
    """``camera`` unchanged if it is a name of :data:`CAMERAS` or a view direction [x, y, z]
    (from the scene towards the camera) of non-zero, finite length; ConfigError otherwise.

    >>> check_camera("xy"), check_camera([1, 0, 0])
    ('xy', [1, 0, 0])
    """
    if isinstance(camera, str):
        ok = camera in CAMERAS
    else:
        v = np.asarray(camera, dtype=float)
        ok = v.shape == (3,) and np.isfinite(v).all() and np.abs(v).max() > 0
    if not ok:
        raise ConfigError(f"camera {camera!r}: expected a named view {CAMERAS} or a direction "
                          "[x, y, z] of non-zero length")
    return camera


def view_direction(camera) -> np.ndarray:
    """The unit vector (3,) of a direction ``camera`` (see :func:`check_camera`), scaled by
    its largest entry first, so that 1e308 or 1e-320 entries neither overflow nor vanish."""
    check_camera(camera)
    v = np.asarray(camera, dtype=float)
    v = v / np.abs(v).max()
    return v / np.linalg.norm(v)
