"""The cantilever box of the mesh-import tests and CalculiX runs on it: 400 x 20 x 10 mm
in 384 quadratic tetrahedra (:mod:`box_mesh`), steel; its link spec, CalculiX's input deck
(C3D10, one material or one per element set), a CalculiX run and its clamped frequencies.
Shared by the tests that compare an imported link with CalculiX."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
from box_mesh import box_tet10

L, B, H = 400.0, 20.0, 10.0  # mm
E, NU, RHO = 2.1e11, 0.3, 7850.0


def make_box():
    """(points (N, 3) mm, tetra10 (384, 10), pivot nodes at x = 0, tip nodes at x = L)."""
    pts, tets = box_tet10(L, B, H, (16, 2, 2))
    pivot = np.flatnonzero(pts[:, 0] == 0.0)
    tip = np.flatnonzero(pts[:, 0] == L)
    return pts, tets, pivot, tip


def write_spec(tmp_path: Path, mesh_file: str, units: str, interfaces: str, extra: str = "",
               materials: str = "", modes: str = "{count: 6}"):
    """Write and load the box's link spec (``mesh_file`` relative to ``tmp_path``)."""
    from pipeline.workflow.link_spec import load_link_spec

    text = f"""name: box
geometry: {{type: mesh, path: {mesh_file}, units: {units}{extra}}}
material: {{E: {E}, nu: {NU}, rho: {RHO}}}
{materials}
interfaces:
{interfaces}
reference: pivot
modes: {modes}
"""
    p = tmp_path / "box.yaml"
    p.write_text(text)
    return load_link_spec(p)


GROUPS = """  - {name: pivot, selector: {type: group, name: pivot}, origin: [0, 0.01, 0.005]}
  - {name: tip, selector: {type: group, name: tip}, origin: [0.4, 0.01, 0.005], kind: rbe3}"""
PLANES = """  - {name: pivot, selector: {type: plane, point: [0, 0.01, 0.005], normal: [1, 0, 0]}}
  - {name: tip, selector: {type: plane, point: [0.4, 0.01, 0.005], normal: [1, 0, 0]},
     kind: rbe3}"""


def calculix_deck(box, clamped: bool = True, storage: bool = False, n: int = 6,
                   parts: dict | None = None) -> str:
    """CalculiX input of the box (mm, t, s): clamped at x = 0, or free with its K and M
    written (``storage``: *FREQUENCY, SOLVER=MATRIXSTORAGE); ``parts`` (element set name ->
    (cell indices, E Pa, nu, rho kg/m^3)) gives each set its own material (default: steel
    for all)."""
    pts, tets, pivot, _ = box
    parts = parts or {"EALL": (np.arange(len(tets)), E, NU, RHO)}
    rows = ["*NODE, NSET=NALL"] + [f"{i + 1}, {p[0]:.12g}, {p[1]:.12g}, {p[2]:.12g}"
                                   for i, p in enumerate(pts)]
    rows += ["*ELEMENT, TYPE=C3D10, ELSET=EALL"] + [
        f"{e + 1}, " + ", ".join(str(k + 1) for k in t) for e, t in enumerate(tets)]
    rows += ["*NSET, NSET=FIX"] + [", ".join(str(k + 1) for k in pivot[i:i + 8])
                                   for i in range(0, len(pivot), 8)]
    for name, (cells, e_mod, nu, rho) in parts.items():
        if name != "EALL":
            rows += [f"*ELSET, ELSET={name}"] + [", ".join(str(k + 1) for k in cells[i:i + 8])
                                                 for i in range(0, len(cells), 8)]
        # CalculiX reads 20 characters a field: 7.849999999999999e-09 would be 7.85
        rows += [f"*MATERIAL, NAME=M{name}", "*ELASTIC", f"{e_mod * 1e-6:.12g}, {nu:.12g}",
                 "*DENSITY", f"{rho * 1e-12:.12g}",
                 f"*SOLID SECTION, ELSET={name}, MATERIAL=M{name}"]
    rows += ["*STEP", "*FREQUENCY" + (", SOLVER=MATRIXSTORAGE" if storage else ""), str(n)]
    rows += (["*BOUNDARY", "FIX, 1, 3"] if clamped else []) + ["*END STEP"]
    return "\n".join(rows) + "\n"


def run_calculix(work: Path, deck: str, job: str = "box") -> str:
    work.mkdir(exist_ok=True)
    (work / f"{job}.inp").write_text(deck)
    run = subprocess.run(["ccx", "-i", job], cwd=work, capture_output=True, text=True,
                         timeout=300, check=False)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    return (work / f"{job}.dat").read_text()


def calculix_frequencies(tmp_path: Path, box, n: int = 6, parts: dict | None = None
                          ) -> np.ndarray:
    """Clamped frequencies, Hz, of CalculiX's C3D10 model of the same mesh (mm, t, s)."""
    return dat_frequencies(run_calculix(tmp_path / "ccx", calculix_deck(box, n=n, parts=parts)),
                           n)


def dat_frequencies(dat: str, n: int) -> np.ndarray:
    """The first n frequencies, Hz, of the eigenvalue table of a CalculiX .dat file."""
    table = dat.split("E I G E N V A L U E   O U T P U T")[1]
    rows = re.findall(r"^\s+(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$", table, re.MULTILINE)
    return np.array([float(r[3]) for r in rows[:n]])
