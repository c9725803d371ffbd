"""Extra frames fixed on a reduced link's frames, for the Python API
(``link_from_reduced(frames=...)``) and the workflow (``frames: {on: ...}``) alike: one
builder (``dynamics.bodies.frame_views``), attached to the base's 3-D motion first and
projected on the loop's plane last."""

from __future__ import annotations

import numpy as np
import pytest
from link_samples import random_link

from pipeline.core.errors import ConfigError
from pipeline.dynamics.bodies import frame_views, link_from_reduced
from pipeline.kinematics.rotations import homogeneous, rot_x


def test_a_point_off_the_plane_keeps_the_in_plane_motion_of_the_base_rotation():
    """A frame 12.5 mm above the plane of an xy loop (a hot spot on a plate's face): the
    base's rotation about x moves it along y by -psi_x d, an in-plane motion the mode has
    there; projecting the base first would lose it."""
    link = random_link(m=3)
    base = link.frame("f1")
    d = np.array([0.0, 0.0, 0.0125])
    local = homogeneous(rot_x(0.3), d)
    views = {v.name: v for v in frame_views(link, range(3), "xy", extra={"hot": ("f1", local)})}
    hot = views["hot"]
    moved = base.phi + np.cross(base.psi, base.pose[:3, :3] @ d)  # rigidly attached, 3-D
    np.testing.assert_allclose(hot.phi[:, :2], moved[:, :2], rtol=1e-14)
    assert np.all(hot.phi[:, 2] == 0.0) and np.all(hot.psi[:, :2] == 0.0)  # then projected
    np.testing.assert_allclose(hot.psi[:, 2], base.psi[:, 2])
    np.testing.assert_allclose(hot.pose, base.pose @ local)
    lost = np.cross(base.psi * [0, 0, 1], base.pose[:3, :3] @ d)  # what projecting first left
    assert np.abs(hot.phi[:, :2] - (base.phi + lost)[:, :2]).max() > 1e-3


def test_the_api_link_has_the_same_frames():
    link = random_link(m=3)
    local = homogeneous(rot_x(0.3), [0.01, -0.02, 0.0125])
    api = link_from_reduced(link, plane="xy", frames={"hot": ("f1", local)})
    views = {v.name: v for v in frame_views(link, range(3), "xy", extra={"hot": ("f1", local)})}
    hot = api.frame("hot")
    np.testing.assert_allclose(hot.phi, views["hot"].phi)
    np.testing.assert_allclose(hot.psi, views["hot"].psi)


def test_an_extra_frame_on_an_unknown_frame_is_named():
    with pytest.raises(ConfigError, match=r"frames\.hot\.on: expected one of \['f0', 'f1', "
                                          r"'f2'\], got 'tip'"):
        frame_views(random_link(m=2), range(2), extra={"hot": ("tip", np.eye(4))})
