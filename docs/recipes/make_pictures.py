"""Draw the pictures of docs/link_specs.md: each solid recipe meshed with the parameters
shown on that page, its surface with the link frame's axes and its named groups.

    python3 docs/recipes/make_pictures.py        # writes docs/recipes/<recipe>.png
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pipeline.meshing.geometry import SolidGeometry
from pipeline.meshing.gmsh_build import build_mesh
from pipeline.post.render import _pyvista, save_png

HERE = Path(__file__).resolve().parent
RECIPES = {
    "bar": {"L": 0.6, "b": 0.05, "h": 0.02},
    "plate_with_bores": {"length": 0.5, "width": 0.12, "thickness": 0.02, "corner_radius": 0.03,
                         "bores": [{"name": "A", "center": [0.06, 0.0], "radius": 0.02},
                                   {"name": "B", "center": [0.44, 0.0], "radius": 0.02}]},
    "bent_plate": {"points": [[0, 0], [0.6, -0.12], [0.9, -0.45]],
                   "point_names": ["pivot", "knee", "tip"], "width": 0.1, "knee_width": 0.15,
                   "thickness": 0.02,
                   "bores": [{"name": "pivot", "at": "pivot", "radius": 0.02},
                             {"name": "knee", "at": "knee", "radius": 0.02},
                             {"name": "tip", "at": "tip", "radius": 0.02}]},
    "box_section": {"length": 1.0, "b": 0.12, "h": 0.2, "wall": 0.01, "end_plates": True,
                    "cross_bores": [{"name": "foot", "x": 0.08, "radius": 0.03, "axis": "y"},
                                    {"name": "cyl", "x": 0.6, "radius": 0.025, "axis": "y",
                                     "offset": -0.05}]},
}


def picture(recipe: str, params: dict, size: float) -> Path:
    pv = _pyvista()
    mesh = build_mesh(SolidGeometry(recipe, params, size, 1), recipe)
    tri = np.asarray(mesh.boundary["triangle"])[:, :3]
    surf = pv.PolyData(mesh.points, np.hstack([np.full((len(tri), 1), 3), tri]).ravel())
    p = pv.Plotter(off_screen=True, window_size=(700, 450))
    p.set_background("white")
    p.add_mesh(surf, color="lightsteelblue", show_edges=True, edge_color="grey")
    ext = float(np.ptp(mesh.points, axis=0).max())
    for k, (axis, colour) in enumerate(zip("xyz", ("red", "green", "blue"))):
        tip = 0.25 * ext * np.eye(3)[k]
        p.add_mesh(pv.Line((0, 0, 0), tip), color=colour, line_width=4)
        p.add_point_labels([1.12 * tip], [axis], text_color=colour, shape=None,
                           font_size=18, show_points=False, always_visible=True)
    names = {g: mesh.points[np.asarray(ids)].mean(axis=0) for g, ids in mesh.groups.items()}
    if names:
        p.add_point_labels(list(names.values()), list(names), font_size=12,
                           shape_opacity=0.6, always_visible=True)
    p.add_text(f"recipe: {recipe}", font_size=11, color="black")
    p.view_vector((1.0, -1.4, 1.1), viewup=(0, 0, 1))
    p.reset_camera()
    image = p.screenshot(return_img=True)
    p.close()
    return save_png(image, HERE / f"{recipe}.png")


if __name__ == "__main__":
    for name, params in RECIPES.items():
        print(picture(name, params, {"bar": 0.01, "box_section": 0.02}.get(name, 0.015)))
