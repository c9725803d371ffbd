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
