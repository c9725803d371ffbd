"""Off-screen renders: right size, not blank, deformed differs from undeformed."""

import numpy as np
import pytest
from link_samples import write_bar

pytestmark = [pytest.mark.render, pytest.mark.gmsh]


def test_render_modes_png(tmp_path):
    from PIL import Image

    from pipeline.post.render import mode_scale, render_modes
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    spec = write_bar(tmp_path, modes=4)
    link, _ = reduce_spec(load_link_spec(spec), tmp_path, tmp_path / "links")
    path = render_modes(link, tmp_path / "modes.png", window_size=(400, 300))
    img = np.asarray(Image.open(path).convert("RGB")).astype(float)
    assert img.shape == (300, 400, 3)
    background = img[0, -1]
    differs = np.abs(img - background).sum(axis=2) > 30
    assert 0.02 < differs.mean() < 0.9  # something drawn, not everything
    # each mode is scaled to the same visible amplitude
    peak = np.abs(link.mode_shapes).max(axis=(1, 2)) * mode_scale(link)
    np.testing.assert_allclose(peak, peak[0])
