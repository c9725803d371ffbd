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


def _text(actor) -> str:
    """The text a pyvista text actor draws (a corner annotation's or a text actor's)."""
    if hasattr(actor, "GetText"):
        return " ".join(str(actor.GetText(k)) for k in range(8))
    return str(actor.GetInput()) if hasattr(actor, "GetInput") else ""


def _colour_share(img, rgb, tol=40):
    return float((np.abs(img - np.asarray(rgb, float)).max(axis=2) < tol).mean())


def test_a_mode_sheet_shows_the_link_frame_and_where_it_is_clamped(tmp_path):
    """Each panel draws the link frame's triad (x red, y green, z blue: which way the
    modes move) and a magenta block where the modes are clamped, and says so in words;
    a sheet without them has none of those colours (viridis has no pure red, blue or
    magenta)."""
    from PIL import Image

    from pipeline.post.render import mode_sheet_plotter
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    link, _ = reduce_spec(load_link_spec(write_bar(tmp_path, modes=4)), tmp_path,
                          tmp_path / "links")
    assert link.summary()["reference_conditions"].startswith("clamped at")
    plotter = mode_sheet_plotter(link, 4, window_size=(800, 600))
    try:
        img = plotter.screenshot(return_img=True).astype(float)
        texts = plotter.renderers[0].actors
    finally:
        plotter.close()
    for rgb in ((255, 0, 0), (0, 0, 255), (255, 0, 255)):
        assert _colour_share(img, rgb) > 2e-4, rgb
    assert any("clamped at 'root'" in _text(a) for a in texts.values())
    bare = mode_sheet_plotter(link, 4, window_size=(800, 600), frames=False)
    try:
        plain = bare.screenshot(return_img=True).astype(float)
    finally:
        bare.close()
    for rgb in ((255, 0, 0), (0, 0, 255), (255, 0, 255)):
        assert _colour_share(plain, rgb) < 1e-5, rgb
    Image.fromarray(img.astype(np.uint8)).save(tmp_path / "sheet.png")
