"""Off-screen renders of reduced links (the only module importing pyvista).

pyvista is imported inside the functions; a missing install raises a
:class:`ConfigError` that says which extra to install.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import ConfigError
from pipeline.invariants.reduced_link import ReducedLink


def _pyvista():
    try:
        import pyvista
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ConfigError("rendering needs pyvista: pip install 'flexmech-pipeline[render]'") \
            from exc
    try:  # headless machines: VTK warns about the missing X display before going off screen
        from vtkmodules.vtkCommonCore import vtkLogger

        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    except ImportError:  # pragma: no cover - depends on the VTK build
        pass
    return pyvista


def link_grid(link: ReducedLink, displacement: np.ndarray | None = None):
    """pyvista PolyData of the link's surface (solids) or centre line (beams).

    Parameters
    ----------
    link : ReducedLink
    displacement : (N, 3) nodal displacement in the body frame, m (optional).
    """
    pv = _pyvista()
    points = link.nodes + (0.0 if displacement is None else displacement)
    if link.surface.size:
        # corner nodes only: a linear surface is enough for a picture
        tri = np.asarray(link.surface)[:, :3]
        return pv.PolyData(points, np.hstack([np.full((tri.shape[0], 1), 3), tri]).ravel())
    lines = np.asarray(link.cells)[:, :2]
    return pv.PolyData(points, lines=np.hstack([np.full((lines.shape[0], 1), 2), lines]).ravel())


def mode_scale(link: ReducedLink, fraction: float = 0.08) -> np.ndarray:
    """(m,) scale factors making each mode's largest displacement ``fraction`` of the size."""
    size = float(np.ptp(link.nodes, axis=0).max())
    peak = np.abs(link.mode_shapes).max(axis=(1, 2))
    return fraction * size / np.where(peak > 0, peak, 1.0)


def render_modes(link: ReducedLink, path: str | Path, n_modes: int = 4,
                 window_size: tuple[int, int] = (1200, 900)) -> Path:
    """Still of the first ``n_modes`` mode shapes (:func:`mode_sheet_plotter`), PNG,
    written atomically; returns the path."""
    plotter = mode_sheet_plotter(link, n_modes, window_size)
    try:
        image = plotter.screenshot(return_img=True)
    finally:
        plotter.close()
    return save_png(image, path)


def mode_sheet_plotter(link: ReducedLink, n_modes: int = 4,
                       window_size: tuple[int, int] = (1200, 900), frames: bool = True):
    """An off-screen pyvista Plotter of the first ``n_modes`` mode shapes (2 x 2 panels;
    the caller screenshots or shows it, and closes it).

    Each panel shows the undeformed link in grey wireframe and the mode deformed by the
    stated scale factor, coloured by displacement magnitude (per unit modal coordinate,
    m); with ``frames``, a triad of the link frame's axes beside the link (x red, y
    green, z blue: the directions the modes move in) and a magenta block on each
    interface the modes are clamped at
    (spheres at a pinned chord's ends), what they are relative to written in the first
    panel.
    """
    pv = _pyvista()
    n = min(n_modes, link.n_modes)
    if n == 0:
        raise ConfigError(f"link {link.name!r}: no modes to render")
    rows, cols = (1, n) if n <= 2 else (2, (n + 1) // 2)
    scales = mode_scale(link)
    conditions = link.summary().get("reference_conditions") if frames else None
    plotter = pv.Plotter(off_screen=True, shape=(rows, cols), window_size=window_size,
                         border=False)
    try:
        for k in range(n):
            plotter.subplot(k // cols, k % cols)
            u = link.mode_shapes[k]
            deformed = link_grid(link, scales[k] * u)
            mag = np.linalg.norm(u, axis=1)
            deformed.point_data["displacement per unit q (m)"] = mag
            plotter.add_mesh(link_grid(link), style="wireframe", color="lightgrey", opacity=0.3)
            plotter.add_mesh(deformed, scalars="displacement per unit q (m)", cmap="viridis",
                             show_scalar_bar=(k == 0), line_width=4)
            if frames:
                _link_frame(pv, plotter, link)
            text = f"mode {k + 1}: {link.frequencies_hz[k]:.4g} Hz (scale x{scales[k]:.3g})"
            if conditions and k == 0:
                text += f"\n{conditions}"
            plotter.add_text(text, font_size=10)
            plotter.view_isometric()
    except BaseException:
        plotter.close()
        raise
    return plotter


def _link_frame(pv, plotter, link: ReducedLink) -> None:
    """The link frame's axes as a triad beside the link (off a lower corner, where the
    link does not hide it; pyvista's corner widget does not draw off screen) and the
    clamped interfaces, in flat colours (a picture's reader, and its test, find them by
    colour)."""
    size = float(np.ptp(link.nodes, axis=0).max())
    lo, hi = link.nodes.min(axis=0), link.nodes.max(axis=0)
    # to the side in an isometric view (along x - y), neither behind nor before the link
    corner = np.array([hi[0], lo[1], lo[2]]) + 0.3 * size * np.array([1.0, -1.0, 0.0])
    for axis, colour in zip(np.eye(3), ("red", (0.0, 0.6, 0.0), "blue"), strict=True):
        plotter.add_mesh(pv.Arrow(start=corner, direction=axis, scale=0.2 * size,
                                  shaft_radius=0.04, tip_radius=0.1),
                         color=colour, lighting=False)
    rc = link.meta.get("reference_conditions") or {}
    where = {f.name: f.pose[:3, 3] for f in link.frames}
    clamped = [rc.get("reference")] + list(rc.get("craig_bampton") or [])
    if rc.get("chord"):  # pinned, not clamped
        for name in (rc.get("reference"), rc["chord"]):
            if name in where:
                plotter.add_mesh(pv.Sphere(radius=0.06 * size, center=where[name]),
                                 color="magenta",
                                 lighting=False)
        return
    for name in clamped:
        if name in where:
            edge = 0.08 * size  # beyond a slender link's section
            plotter.add_mesh(pv.Cube(center=where[name], x_length=edge, y_length=edge,
                                     z_length=edge), color="magenta", lighting=False)


def save_png(image: np.ndarray, path: str | Path) -> Path:
    """Write an (h, w, 3|4) uint8 image as PNG atomically; return the path."""
    from PIL import Image

    path = Path(path)
    with atomic_path(path) as tmp:
        Image.fromarray(image).save(tmp, format="PNG")
    return path
