"""Off-screen pictures of a whole machine: stills, several positions in one still, and
animations. Flexible links are coloured by their elastic displacement (magnified by a
stated factor); rigid links are grey. pyvista is imported inside the functions."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.core.atomic import atomic_path
from pipeline.core.errors import ConfigError
from pipeline.kinematics import evaluate_tree
from pipeline.post.render import _pyvista, save_png

_CAMERAS = ("xy", "xz", "yz", "iso")


def link_poses(mech, q) -> np.ndarray:
    """(n_links, 4, 4) body-to-ground transforms at q (compute once per configuration)."""
    return evaluate_tree(mech, np.asarray(q, dtype=float), derivatives=False).A


def posed_points(mech, shape, q, scale: float = 1.0, poses=None) -> tuple[np.ndarray, np.ndarray]:
    """((N, 3) ground points, (N,) elastic displacement magnitude, m) of a link at q.

    The rigid motion is exact; only the elastic part sum_a u_a eta_a is multiplied by
    ``scale``. The magnitude is the true (unscaled) elastic displacement. ``poses``:
    :func:`link_poses` at q, when several links are drawn at the same q.
    """
    q = np.asarray(q, dtype=float)
    li = mech.link_index(shape.link)
    A = (link_poses(mech, q) if poses is None else poses)[li]
    X = shape.points
    if shape.modes is not None and shape.modes.shape[0]:
        eta = q[mech.modal_index[li]]
        u = np.tensordot(eta, shape.modes, axes=(0, 0))
    else:
        u = np.zeros_like(X)
    P = (X + scale * u) @ A[:3, :3].T + A[:3, 3]
    return P, np.linalg.norm(u, axis=1)


def _polydata(pv, shape, P):
    if shape.triangles is not None:
        t = shape.triangles
        return pv.PolyData(P, np.hstack([np.full((len(t), 1), 3), t]).ravel())
    l = shape.lines
    return pv.PolyData(P, lines=np.hstack([np.full((len(l), 1), 2), l]).ravel())


def _camera(plotter, camera):
    """Named view, or a view direction (3,) (from the scene towards the camera; z up)."""
    if not isinstance(camera, str):
        v = np.asarray(camera, dtype=float)
        if v.shape != (3,) or not np.linalg.norm(v) > 0:
            raise ConfigError(f"camera: expected a name {_CAMERAS} or a direction [x, y, z], "
                              f"got {camera!r}")
        up = (0.0, 0.0, 1.0) if abs(v[2]) < 0.9 * np.linalg.norm(v) else (0.0, 1.0, 0.0)
        plotter.view_vector(v, viewup=up)
        return
    if camera not in _CAMERAS:
        raise ConfigError(f"camera: expected one of {_CAMERAS}, got {camera!r}")
    {"xy": plotter.view_xy, "xz": plotter.view_xz, "yz": plotter.view_yz,
     "iso": plotter.view_isometric}[camera]()


def _add_machine(plotter, pv, mech, shapes, q, scale, clim, opacity=1.0, ghost=False):
    """Add every link at q; returns the largest elastic displacement drawn (m)."""
    peak = 0.0
    poses = link_poses(mech, q)
    for shape in shapes.values():
        P, d = posed_points(mech, shape, q, scale, poses)
        mesh = _polydata(pv, shape, P)
        if ghost:
            plotter.add_mesh(mesh, style="wireframe", color="dimgrey", opacity=0.4, line_width=2)
            continue
        if shape.modes is not None and shape.modes.shape[0]:
            mesh.point_data["elastic displacement, mm"] = 1e3 * d
            plotter.add_mesh(mesh, scalars="elastic displacement, mm", cmap="viridis",
                             clim=clim, opacity=opacity, line_width=5,
                             show_scalar_bar=False)
            peak = max(peak, float(d.max(initial=0.0)))
        else:
            plotter.add_mesh(mesh, color="silver", opacity=opacity, line_width=5,
                             smooth_shading=False)
    return peak


def _label_anchor(mech, shapes, q, scale) -> np.ndarray:
    """Where to write a configuration's label: at its largest elastic displacement (the
    flexible links' far end), else at the centre of the machine."""
    best, anchor = -1.0, None
    for s in shapes.values():
        P, d = posed_points(mech, s, q, scale)
        if s.modes is not None and d.size and d.max() > best:
            best, anchor = float(d.max()), P[int(np.argmax(d))]
    if anchor is None:
        anchor = np.mean([posed_points(mech, s, q, scale)[0].mean(axis=0)
                          for s in shapes.values()], axis=0)
    return anchor


def _clim(mech, shapes, Q, scale):
    top = 0.0
    for q in Q:
        poses = link_poses(mech, q)
        for s in shapes.values():
            top = max(top, float(posed_points(mech, s, q, 1.0, poses)[1].max(initial=0.0)))
    return [0.0, max(1e3 * top, 1e-9)]


def _bar(plotter, scale, clim):
    if clim[1] > 1e-9:
        mesh = _pyvista().PolyData(np.zeros((1, 3)))
        mesh.point_data[f"elastic displacement, mm (drawn x{scale:g})"] = [0.0]
        actor = plotter.add_mesh(mesh, scalars=f"elastic displacement, mm (drawn x{scale:g})",
                                 cmap="viridis", clim=clim, point_size=0.0, opacity=0.0,
                                 show_scalar_bar=True)
        return actor
    return None


def render_machine(path, mech, shapes, q, *, scale: float = 1.0, title: str | None = None,
                   camera: str = "iso", ghost_q=None,
                   window_size: tuple[int, int] = (1200, 900)) -> Path:
    """PNG of the machine at q (written atomically); optional grey wireframe at ``ghost_q``
    (e.g. the same configuration without elastic deformation)."""
    return render_positions(path, mech, shapes, [q], None, scale=scale, title=title,
                            camera=camera, ghost_q=None if ghost_q is None else [ghost_q],
                            window_size=window_size)


def render_positions(path, mech, shapes, Q, labels=None, *, scale: float = 1.0,
                     title: str | None = None, camera: str = "iso", ghost_q=None,
                     window_size: tuple[int, int] = (1200, 900)) -> Path:
    """One PNG with the machine at several configurations (e.g. lower/middle/upper),
    one shared colour range; labels are written next to each configuration; ``ghost_q``:
    configurations drawn as grey wireframes (e.g. the undeformed ones)."""
    pv = _pyvista()
    Q = [np.asarray(q, dtype=float) for q in Q]
    clim = _clim(mech, shapes, Q, scale)
    plotter = pv.Plotter(off_screen=True, window_size=window_size)
    try:
        plotter.set_background("white")
        for g in ghost_q or ():
            _add_machine(plotter, pv, mech, shapes, g, 0.0, clim, ghost=True)
        for k, q in enumerate(Q):
            _add_machine(plotter, pv, mech, shapes, q, scale, clim,
                         opacity=1.0 if len(Q) == 1 else 0.9)
            if labels:
                anchor = _label_anchor(mech, shapes, q, scale)
                plotter.add_point_labels([anchor], [str(labels[k])], font_size=14,
                                         shape_opacity=0.3, always_visible=True)
        _bar(plotter, scale, clim)
        if title:
            plotter.add_text(title, font_size=11, color="black")
        _camera(plotter, camera)
        plotter.reset_camera()
        image = plotter.screenshot(return_img=True)
    finally:
        plotter.close()
    return save_png(image, path)


def animate_machine(path, mech, shapes, t, Q, *, scale: float = 1.0, fps: int = 15,
                    max_frames: int = 60, camera: str = "iso",
                    window_size: tuple[int, int] = (800, 600)) -> Path:
    """GIF (or MP4 if the suffix is .mp4 and imageio-ffmpeg is installed) of the run; fixed
    camera framing the whole motion and one colour range; time in the title."""
    import imageio.v2 as imageio

    pv = _pyvista()
    path = Path(path)
    t = np.asarray(t, dtype=float)
    Q = np.asarray(Q, dtype=float)
    if len(t) == 0:
        raise ConfigError(f"{path.name}: nothing to animate (no output times)")
    picks = np.unique(np.linspace(0, len(t) - 1, min(max_frames, len(t))).round().astype(int))
    clim = _clim(mech, shapes, Q[picks], scale)
    allP = np.vstack([posed_points(mech, s, Q[k], scale)[0] for k in picks[:: max(
        1, len(picks) // 8)] for s in shapes.values()])
    bounds = np.column_stack([allP.min(axis=0), allP.max(axis=0)]).ravel()
    frames = []
    plotter = pv.Plotter(off_screen=True, window_size=window_size)
    try:
        plotter.set_background("white")
        for k in picks:
            plotter.clear()
            _add_machine(plotter, pv, mech, shapes, Q[k], scale, clim)
            _bar(plotter, scale, clim)
            plotter.add_text(f"t = {t[k]:.3f} s", font_size=12, color="black")
            _camera(plotter, camera)
            plotter.reset_camera(bounds=bounds)
            frames.append(plotter.screenshot(return_img=True))
    finally:
        plotter.close()
    suffix = path.suffix.lower()
    if suffix == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise ConfigError(f"{path.name}: MP4 needs imageio-ffmpeg (pip install "
                              "imageio-ffmpeg); use format: gif") from None
    with atomic_path(path) as tmp:
        if suffix == ".mp4":
            imageio.mimsave(tmp, frames, fps=fps, format="FFMPEG")
        else:
            imageio.mimsave(tmp, frames, format="GIF", duration=1000.0 / fps, loop=0)
    return path
