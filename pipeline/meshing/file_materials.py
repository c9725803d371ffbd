"""The materials an FE tool's input file gives its solid elements, by element set.

* Abaqus / CalculiX ``.inp``: ``*MATERIAL, NAME=`` with its ``*ELASTIC`` (isotropic: E, nu)
  and ``*DENSITY`` (rho) lines; ``*SOLID SECTION, ELSET=, MATERIAL=`` gives a set its
  material.
* Nastran ``.bdf`` / ``.nas`` / ``.fem``: ``MAT1`` (MID, E, G, NU, RHO; E or NU from the
  other two where one is blank) and ``PSOLID`` (PID, MID); the cells of property ``n``
  are the element set ``PID<n>`` (:func:`pipeline.meshing.imported.read_mesh`). Free field
  (commas), small field (8 characters) and large field (``MAT1*``, 16 characters, with its
  ``*`` continuation line) cards; Nastran's reals without an ``E`` (``2.1+5``) read as such.

Values come in the file's consistent units: its length unit and a mass unit (mm and t:
N, MPa, t/mm^3), seconds; they are returned in SI. What is not an isotropic elastic
material (an anisotropic ``*ELASTIC``, ``MAT2``/``MAT9``, a material without a density) is
refused with the file's line.
"""

from __future__ import annotations

import re
from pathlib import Path

from pipeline.core.errors import ConfigError

__all__ = ["read_file_materials"]

#: Nastran reals may drop the E of their exponent: 2.1+5, 7.85-9
_NASTRAN_REAL = re.compile(r"^([+-]?(?:\d+\.?\d*|\.\d+))([+-]\d+)$")


def read_file_materials(path: Path, fmt: str, length: float, mass: float
                        ) -> dict[str, tuple[float, float, float]]:
    """{element set: (E Pa, nu, rho kg/m^3)} of the solid sections of the FE input ``path``
    (meshio format ``abaqus`` or ``nastran``), its values scaled from the file's units
    (``length`` m and ``mass`` kg per file unit, seconds).

    Raises
    ------
    ConfigError
        Another format; no section; an unreadable, incomplete or non-isotropic material;
        a section naming a material the file does not define. The message names the file
        and its line.
    """
    text = path.read_text(errors="replace").splitlines()
    if fmt == "abaqus":
        found = _abaqus(text, path)
    elif fmt == "nastran":
        found = _nastran(text, path)
    else:
        raise ConfigError(f"{path}: materials from the file are read from Abaqus/CalculiX .inp "
                          f"and Nastran .bdf files, not from {fmt} files: give materials by "
                          "element set in the spec")
    if not found:
        raise ConfigError(f"{path}: has no solid section (*SOLID SECTION or PSOLID) with a "
                          "material: give the materials in the spec")
    stress, density = mass / length, mass / length**3
    return {name: (E * stress, nu, rho * density) for name, (E, nu, rho) in found.items()}


def _keyword(line: str) -> tuple[str, dict[str, str]]:
    """(KEYWORD, {PARAMETER: value}) of an Abaqus keyword line."""
    parts = [p.strip() for p in line[1:].split(",")]
    params = {}
    for p in parts[1:]:
        key, _, value = p.partition("=")
        params[key.strip().upper()] = value.strip()
    return parts[0].upper(), params


def _numbers(line: str, path: Path, k: int, what: str) -> list[float]:
    try:
        return [float(x) for x in line.split(",") if x.strip()]
    except ValueError:
        raise ConfigError(f"{path}:{k + 1}: {what}: expected numbers, got {line.strip()!r}") \
            from None


def _abaqus(lines: list[str], path: Path) -> dict[str, tuple[float, float, float]]:
    materials: dict[str, dict] = {}
    sections: list[tuple[str, str, int]] = []
    current, block = None, None
    for k, raw in enumerate(lines):
        line = raw.strip()
        if not line or line.startswith("**"):
            continue
        if line.startswith("*"):
            key, params = _keyword(line)
            block = None
            if key == "MATERIAL":
                current = params.get("NAME", "").upper()
                materials[current] = {"line": k + 1}
            elif key == "ELASTIC" and current is not None:
                kind = params.get("TYPE", "ISOTROPIC").upper()
                if kind != "ISOTROPIC":
                    raise ConfigError(f"{path}:{k + 1}: *ELASTIC, TYPE={kind}: the FE stage "
                                      "takes isotropic materials")
                block = "elastic"
            elif key == "DENSITY" and current is not None:
                block = "density"
            elif key == "SOLID SECTION":
                sections.append((params.get("ELSET", ""), params.get("MATERIAL", "").upper(),
                                 k + 1))
            elif key not in ("ELASTIC", "DENSITY", "EXPANSION", "CONDUCTIVITY",
                             "SPECIFIC HEAT", "DAMPING", "PLASTIC"):
                current = None
            continue
        if block == "elastic" and "E" not in materials[current]:
            values = _numbers(line, path, k, "*ELASTIC")
            if len(values) < 2:
                raise ConfigError(f"{path}:{k + 1}: *ELASTIC: expected E, nu")
            materials[current]["E"], materials[current]["nu"] = values[0], values[1]
        elif block == "density" and "rho" not in materials[current]:
            materials[current]["rho"] = _numbers(line, path, k, "*DENSITY")[0]
    out = {}
    for elset, name, k in sections:
        if name not in materials:
            raise ConfigError(f"{path}:{k}: *SOLID SECTION, ELSET={elset}: material {name!r} "
                              "is not defined in the file")
        out[elset] = _complete(materials[name], path, f"*MATERIAL, NAME={name}")
    return out


def _complete(m: dict, path: Path, what: str) -> tuple[float, float, float]:
    """(E, nu, rho) of a material read from the file, each given."""
    for key in ("E", "nu", "rho"):
        if m.get(key) is None:
            raise ConfigError(f"{path}:{m['line']}: {what}: has no {key}: a link's material "
                              "needs E, nu and rho (a density)")
    return float(m["E"]), float(m["nu"]), float(m["rho"])


def _nastran_real(field: str, path: Path, k: int, what: str) -> float | None:
    s = field.strip().replace("D", "E").replace("d", "e")
    if not s:
        return None
    m = _NASTRAN_REAL.match(s)
    try:
        return float(f"{m.group(1)}e{m.group(2)}" if m else s)
    except ValueError:
        raise ConfigError(f"{path}:{k + 1}: {what}: expected a number, got {s!r}") from None


def _nastran_fields(lines: list[str], k: int) -> tuple[list[str], int]:
    """The fields of the bulk card starting at line k (its continuations joined) and the
    line after it."""
    line = lines[k].rstrip("\n")
    if "," in line:
        fields = [f.strip() for f in line.split(",")]
        fields = fields[:9]
        nxt = k + 1
        while nxt < len(lines) and lines[nxt][:1] in ("+", "*", ",") and \
                "," in lines[nxt]:
            fields += [f.strip() for f in lines[nxt].split(",")[1:9]]
            nxt += 1
        return fields, nxt
    large = line[:8].strip().endswith("*")
    width, count = (16, 4) if large else (8, 8)
    fields = [line[:8].strip()] + [line[8 + i * width: 8 + (i + 1) * width].strip()
                                   for i in range(count)]
    nxt = k + 1
    while nxt < len(lines) and lines[nxt][:1] in ("+", "*"):
        cont = lines[nxt]
        fields += [cont[8 + i * width: 8 + (i + 1) * width].strip() for i in range(count)]
        nxt += 1
    return fields, nxt


def _nastran(lines: list[str], path: Path) -> dict[str, tuple[float, float, float]]:
    mats: dict[int, dict] = {}
    props: list[tuple[int, int, int]] = []
    k = 0
    while k < len(lines):
        name = lines[k][:8].split(",")[0].strip().upper().rstrip("*")
        if name in ("MAT2", "MAT8", "MAT9"):
            raise ConfigError(f"{path}:{k + 1}: {name}: the FE stage takes isotropic "
                              "materials (MAT1)")
        if name not in ("MAT1", "PSOLID"):
            k += 1
            continue
        fields, nxt = _nastran_fields(lines, k)
        fields += [""] * 9

        def real(i, what, fields=fields, k=k):
            return _nastran_real(fields[i], path, k, what)

        try:
            ident = int(fields[1])
        except ValueError:
            raise ConfigError(f"{path}:{k + 1}: {name}: expected an id, got {fields[1]!r}") \
                from None
        if name == "MAT1":
            E, G, nu, rho = (real(2, "MAT1 E"), real(3, "MAT1 G"), real(4, "MAT1 NU"),
                             real(5, "MAT1 RHO"))
            if E is None and G is not None and nu is not None:
                E = 2.0 * G * (1.0 + nu)
            if nu is None and E is not None and G is not None:
                nu = E / (2.0 * G) - 1.0
            mats[ident] = {"E": E, "nu": nu, "rho": rho, "line": k + 1}
        else:
            try:
                props.append((ident, int(fields[2]), k + 1))
            except ValueError:
                raise ConfigError(f"{path}:{k + 1}: PSOLID {ident}: expected a material id, "
                                  f"got {fields[2]!r}") from None
        k = nxt
    out = {}
    for pid, mid, k in props:
        if mid not in mats:
            raise ConfigError(f"{path}:{k}: PSOLID {pid}: material {mid} (MAT1) is not defined "
                              "in the file")
        out[f"PID{pid}"] = _complete(mats[mid], path, f"MAT1 {mid}")
    return out
