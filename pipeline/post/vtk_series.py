"""ParaView time series of a machine: per output time a multiblock (.vtm) whose blocks are
the links by name, each a VTU (meshio), and a PVD index of them by time."""

from __future__ import annotations

import logging
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from pipeline.core.atomic import atomic_open, atomic_path
from pipeline.core.progress import progress_counter
from pipeline.post.scene import drawn_poses, posed_points

logger = logging.getLogger(__name__)


def link_grids(mech, shapes, q, scale: float = 1.0) -> list[tuple]:
    """[(link name, points (N, 3), cells [(type, array)], point data)] of every link at q.

    The points are drawn with the deformation ``scale`` times along the whole chain
    (:func:`pipeline.post.scene.posed_points`). Point data: elastic ``displacement``
    (ground axes, m; from where the point is with every modal coordinate zero, so a link
    carried by a flexible one shows that too) and its magnitude, and ``von_mises`` (Pa,
    NaN on links without stress modes) when a link has stress modes."""
    poses = drawn_poses(mech, q, scale)
    rigid = drawn_poses(mech, q, 0.0)
    stressed = any(s.stress is not None for s in shapes.values())
    out = []
    for name, s in shapes.items():
        P, _ = posed_points(mech, s, q, scale, poses)
        P0, _ = posed_points(mech, s, q, 0.0, rigid)
        d = (P - P0) / scale if scale else np.zeros_like(P)
        data = {"displacement": d, "displacement_magnitude": np.linalg.norm(d, axis=1)}
        if stressed:
            v = s.von_mises(np.asarray(q, float)[mech.modal_index[mech.link_index(s.link)]])
            data["von_mises"] = np.full(len(P), np.nan) if v is None else v
        cells = [(kind, c) for kind, c in (("triangle", s.triangles), ("line", s.lines))
                 if c is not None]
        out.append((name, P, cells, data))
    return out


def machine_blocks(mech, shapes, q, scale: float = 1.0):
    """A pyvista MultiBlock of the machine at q (n,): one block per link, named by it, its
    surface (or lines) drawn with the deformation ``scale`` times, point data as
    :func:`link_grids` (what each frame of :func:`write_vtk_series` holds), for a notebook
    to plot or slice."""
    import pyvista as pv

    blocks = pv.MultiBlock()
    for name, P, cells, data in link_grids(mech, shapes, q, scale):
        faces = [np.column_stack([np.full(len(c), c.shape[1]), c]).ravel()
                 for kind, c in cells if kind == "triangle"]
        lines = [np.column_stack([np.full(len(c), 2), c]).ravel()
                 for kind, c in cells if kind == "line"]
        mesh = pv.PolyData(np.asarray(P, dtype=float),
                           faces=np.concatenate(faces) if faces else None,
                           lines=np.concatenate(lines) if lines else None)
        for key, value in data.items():
            mesh.point_data[key] = value
        blocks[name] = mesh
    return blocks


def machine_grid(mech, shapes, q, scale: float = 1.0):
    """(points (N, 3), cells [(type, array)], point data, cell data) of all links at q in
    one grid (:func:`link_grids`, concatenated); cell data ``link_id``: the index of each
    cell's link in ``shapes``."""
    pts, by_kind, ids, n0 = [], {}, {}, 0
    grids = link_grids(mech, shapes, q, scale)
    for i, (_, P, cells, _) in enumerate(grids):
        pts.append(P)
        for kind, c in cells:
            by_kind.setdefault(kind, []).append(c + n0)
            ids.setdefault(kind, []).append(np.full(len(c), i))
        n0 += len(P)
    kinds = [k for k in ("triangle", "line") if k in by_kind]
    data = {key: np.concatenate([g[3][key] for g in grids]) for key in grids[0][3]}
    return (np.vstack(pts), [(k, np.vstack(by_kind[k])) for k in kinds], data,
            {"link_id": [np.concatenate(ids[k]) for k in kinds]})


def peak_von_mises(mech, shapes, Q, chunk: int = 64) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per link with stress modes: ((N,) the largest von Mises stress at each of its points
    over the rows of Q (T, n), Pa; (N,) the row where it occurs)."""
    from pipeline.fem.stress import von_mises

    Q = np.asarray(Q, dtype=float)
    out = {}
    for name, s in shapes.items():
        if s.stress is None:
            continue
        eta = Q[:, mech.modal_index[mech.link_index(s.link)]]
        top = np.full(len(s.points), -1.0)
        at = np.zeros(len(s.points), dtype=int)
        for start in range(0, len(Q), chunk):  # bounded memory: chunk x N x 6
            v = von_mises(np.einsum("ta,anc->tnc", eta[start:start + chunk], s.stress))
            k = np.argmax(v, axis=0)
            best = v[k, np.arange(v.shape[1])]
            better = best > top
            top[better], at[better] = best[better], start + k[better]
        out[name] = (top, at)
    return out


def write_peak_stress(path, mech, shapes, t, Q) -> Path | None:
    """One VTU of the machine at its first output with the point data ``von_mises_max``
    (Pa) and ``time_of_max`` (s): the largest von Mises stress at each point over every
    output time (not only the frames of the series); NaN on links without stress modes.
    None when no link has stress modes."""
    import meshio

    peaks = peak_von_mises(mech, shapes, Q)
    if not peaks:
        return None
    t = np.asarray(t, dtype=float)
    P, cells, _, cdata = machine_grid(mech, shapes, Q[0], 0.0)
    vmax, tmax = [], []
    for name, s in shapes.items():
        top, at = peaks.get(name, (np.full(len(s.points), np.nan), None))
        vmax.append(top)
        tmax.append(np.full(len(s.points), np.nan) if at is None else t[at])
    mesh = _mesh32(P, cells, {"von_mises_max": np.concatenate(vmax),
                              "time_of_max": np.concatenate(tmax)}, cdata)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")
    return path


def _mesh32(P, cells, point_data, cell_data):
    """A meshio mesh in single precision and 32-bit indices (a picture needs no more)."""
    import meshio

    return meshio.Mesh(P.astype(np.float32), [(c, a.astype(np.int32)) for c, a in cells],
                       point_data={k: v.astype(np.float32) for k, v in point_data.items()},
                       cell_data={k: [a.astype(np.int32) for a in v]
                                  for k, v in cell_data.items()})


def _evenly(n: int, most: int) -> np.ndarray:
    """At most ``most`` indices of range(n), evenly spread, first and last included."""
    return np.unique(np.linspace(0, n - 1, min(most, n)).round().astype(int))


def _file_stem(name: str) -> str:
    """A file name's stem from a link's name (what a file system takes)."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name) or "link"


def _write_frame(folder: Path, stem: str, grids) -> list[Path]:
    """One frame as a multiblock: ``stem/<link>.vtu`` per link and ``stem.vtm`` naming
    them by their links (what ParaView shows as the blocks). Returns the files written."""
    import meshio

    (folder / stem).mkdir(exist_ok=True)
    files, blocks = [], []
    for i, (link, P, cells, data) in enumerate(grids):
        rel = f"{stem}/{i:02d}_{_file_stem(link)}.vtu"
        meshio.write(folder / rel, _mesh32(P, cells, data, {}))
        files.append(folder / rel)
        blocks.append(f'    <DataSet index="{i}" name={quoteattr(link)} file={quoteattr(rel)}/>')
    vtm = folder / f"{stem}.vtm"
    with atomic_open(vtm, "w") as fh:
        fh.write('<?xml version="1.0"?>\n<VTKFile type="vtkMultiBlockDataSet" version="1.0">\n'
                 "  <vtkMultiBlockDataSet>\n" + "\n".join(blocks) +
                 "\n  </vtkMultiBlockDataSet>\n</VTKFile>\n")
    return [vtm, *files]


def write_vtk_series(folder, mech, shapes, t, Q, *, scale: float = 1.0, name: str = "machine",
                     max_steps: int = 100, max_bytes: float | None = None) -> Path:
    """Write the machine's ParaView time series into ``folder``: per output time a
    multiblock ``<name>_<k>.vtm`` whose blocks are the links by name (``<name>_<k>/*.vtu``;
    at most ``max_steps`` frames, evenly thinned), and ``<name>.pvd`` indexing them by
    time. Point data: elastic displacement (ground axes, m) and its magnitude, von Mises
    stress (Pa) where links have stress modes. Returns the .pvd path.

    Points and fields are written in single precision (zlib-compressed): a picture
    needs no more, and it halves the files. The size of the series is estimated from
    the first frame and logged; beyond ``max_bytes`` the frames are thinned further
    (evenly, at least 2). A terminal shows a progress bar.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    t = np.asarray(t, dtype=float)
    picks = _evenly(len(t), max_steps)
    entries = []
    with progress_counter(len(picks), f"VTU {name}") as advance:
        n = 0
        while n < len(picks):
            k = picks[n]
            stem = f"{name}_{k:05d}"
            written = _write_frame(folder, stem, link_grids(mech, shapes, Q[k], scale))
            if n == 0:
                size = sum(p.stat().st_size for p in written)
                if max_bytes is not None and size * len(picks) > max_bytes:
                    # 10 % margin: compressed frames differ in size
                    fit = max(2, int(0.9 * max_bytes // size))
                    logger.info("VTU %s: %d frames of %.2f MB exceed the budget of %.1f MB; "
                                "thinned to %d", name, len(picks), size / 1e6, max_bytes / 1e6,
                                min(fit, len(picks)))
                    picks = _evenly(len(t), min(fit, len(picks)))  # starts at frame 0 too
                logger.info("VTU %s: %d frames, about %.1f MB", name, len(picks),
                            size * len(picks) / 1e6)
            entries.append(f'    <DataSet timestep="{t[k]:.9g}" part="0" '
                           f'file={quoteattr(stem + ".vtm")}/>')
            n += 1
            advance(n)
    pvd = folder / f"{name}.pvd"
    with atomic_open(pvd, "w") as fh:
        fh.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
                 "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    return pvd
