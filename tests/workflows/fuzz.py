"""A seeded mutation fuzzer of workflow and link-spec files.

Each mutant is a valid input changed in one place (a value's type, sign or finiteness, an
unknown key, a deleted key, a null, a swapped container, a damaged line of text). Checking
one loads it (and, for rigid machines, builds it as ``validate --build`` does) and sorts the
outcome:

* ``ok``: accepted, and the mutation may be valid;
* ``clear``: refused with a PipelineError; a ConfigError must start ``file:line:``;
* ``silent``: accepted although the mutation makes it invalid for certain;
* ``traceback``: any other exception (what a user would see as a traceback), numpy's
  RuntimeWarnings included (lines on the user's terminal without file:line);
* ``hang``: not done within the time limit.

Only ``ok`` and ``clear`` are acceptable.
"""

from __future__ import annotations

import math
import random
import re
import signal
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from pipeline.core.errors import ConfigError, PipelineError

#: keys whose numbers must be > 0 wherever they appear in a workflow or link spec
POSITIVE = {"mass", "t_end", "outputs", "radius", "E", "rho", "mesh_size", "element_size",
            "rtol", "atol", "step", "max_step", "max_steps", "count", "A", "Iy", "Iz", "J",
            "fps", "max_frames", "scale"}
#: subtrees whose keys and values are checked when the machine is built, not at load
FREE_FORM = {"drivers", "quick", "set", "spec_overrides", "params", "description", "title",
             "ylabel"}
TIME_LIMIT = 20  # s per mutant


@dataclass(frozen=True)
class Mutant:
    text: str
    op: str
    path: tuple
    must_fail: bool  # invalid for certain (strict schema), whatever the context
    files: tuple[tuple[str, bytes], ...] = ()  # written beside the mutant (its .geo, STEP)


def _leaves(data, path=()):
    """(path, value) of every node, depth first."""
    yield path, data
    if isinstance(data, dict):
        for k, v in data.items():
            yield from _leaves(v, path + (k,))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from _leaves(v, path + (i,))


def _free(path) -> bool:
    if any(p in FREE_FORM for p in path if isinstance(p, str)):
        return True
    # a force's own parameters (ForceSpec keeps unknown keys for its builder)
    return len(path) >= 3 and path[0] == "forces" and path[2] not in ("name", "type")


def _set(data, path, value):
    node = data
    for p in path[:-1]:
        node = node[p]
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value


_DELETE = object()


def mutate(text: str, rng: random.Random, rigid_build: bool, link: bool = False) -> Mutant:
    """One mutant of the YAML ``text``. ``rigid_build``: the check builds the machine, so
    the free-form parts are checked too; ``link``: a link spec, whose geometry the
    ``mesh`` operator replaces by one aimed at a meshing guard (then meshed)."""
    data = yaml.safe_load(text)
    nodes = [(p, v) for p, v in _leaves(data) if p]
    op = rng.choice(["bool", "string", "nonfinite", "negative", "unknown_key", "delete",
                     "null", "container", "text", "huge", "name", "inertia", "table", "axis",
                     "mesh"])
    if op in ("inertia", "table", "axis") and rigid_build:
        guarded = _guarded(data, op, rng)
        if guarded is not None:
            return guarded
    if op == "mesh" and link and isinstance(data, dict):
        return _meshing(data, rng)
    if op == "text":
        lines = text.splitlines(keepends=True)
        k = rng.randrange(len(lines))
        line = lines[k]
        choice = rng.choice(["drop_char", "indent", "colon", "tab", "quote", "dup"])
        if choice == "drop_char" and len(line) > 1:
            j = rng.randrange(len(line) - 1)
            line = line[:j] + line[j + 1:]
        elif choice == "indent":
            line = "   " + line
        elif choice == "colon":
            line = line.rstrip("\n") + ": :\n"
        elif choice == "tab":
            line = "\t" + line
        elif choice == "quote":
            line = line.replace(":", ': "', 1)
        else:
            line = line + line
        lines[k] = line
        return Mutant("".join(lines), f"text/{choice}", (k + 1,), False)
    numbers = [(p, v) for p, v in nodes if isinstance(v, int | float)
               and not isinstance(v, bool)]
    strings = [(p, v) for p, v in nodes if isinstance(v, str)]
    maps = [(p, v) for p, v in nodes if isinstance(v, dict)] + [((), data)]
    conts = [(p, v) for p, v in nodes if isinstance(v, dict | list)]
    if op in ("bool", "string", "nonfinite", "huge") and numbers:
        path, v = rng.choice(numbers)
        new = {"bool": rng.choice([True, False]), "string": "oops",
               "nonfinite": rng.choice([math.nan, math.inf, -math.inf]),
               "huge": rng.choice([1e308, -1e308, 10 ** 30])}[op]
        _set(data, path, new)
        certain = op in ("bool", "string", "nonfinite") and (rigid_build or not _free(path))
        # a driver's or force's number may be legitimately any real (huge): not certain
        return Mutant(yaml.safe_dump(data, sort_keys=False), op, path, certain)
    if op == "negative":
        pos = [(p, v) for p, v in numbers if isinstance(p[-1], str) and p[-1] in POSITIVE
               and v > 0]
        if pos:
            path, v = rng.choice(pos)
            _set(data, path, -abs(v) - 1)
            return Mutant(yaml.safe_dump(data, sort_keys=False), op, path, not _free(path))
    if op == "unknown_key":
        path, m = rng.choice(maps)
        m["zzz_misspelt"] = 1
        # a map of coordinate names takes any name with a number (checked at the build);
        # elsewhere an unknown key, or a link or frame that is a number, is an error
        named = path[-1:] in (("coordinates",), ("velocities",))
        certain = not _free(path + ("zzz_misspelt",)) and (rigid_build or not named)
        return Mutant(yaml.safe_dump(data, sort_keys=False), op, path, certain)
    if op == "name" and strings:
        path, v = rng.choice(strings)
        _set(data, path, rng.choice(["..", "a/b", "", " ", "x" * 300, "é", "../../etc"]))
        return Mutant(yaml.safe_dump(data, sort_keys=False, allow_unicode=True), op, path,
                      False)
    if op == "container" and conts:
        path, v = rng.choice(conts)
        _set(data, path, [] if isinstance(v, dict) else {})
        return Mutant(yaml.safe_dump(data, sort_keys=False), op, path, False)
    path, v = rng.choice(nodes)
    _set(data, path, _DELETE if op == "delete" else None)
    return Mutant(yaml.safe_dump(data, sort_keys=False), op if op in ("delete", "null")
                  else "null", path, False)


#: inertias a rigid link may be given: (value, refused for certain). Negative or
#: unsymmetric ones no body has; a thin rod, a point mass and a reflected inertia are idioms
#: (accepted, unless the joints let them move without inertia: not certain either way)
_INERTIAS = [([-0.1, 2.3, 2.3, 0, 0, 0], True), ([[1, 0.1, 0], [0.2, 1, 0], [0, 0, 1]], True),
             ([0.003, 2.3, 2.3, 3.0, 0, 0], True), ([0, 2.3, 2.3, 0, 0, 0], False),
             ([0, 0, 0, 0, 0, 0], False), ([0.02, 0.02, 1.0066, 0, 0, 0], False)]
#: files a driver table may name: devices, folders and missing files are refused
_TABLE_FILES = ["/dev/zero", "/dev/null", "/", "no_such_table.csv"]


def _guarded(data, op: str, rng: random.Random) -> Mutant | None:
    """A mutant aimed at one of the build's guards (rigid machines, which are built):
    an inertia, a driver table that is not a regular file, a zero frame axis."""
    links = data.get("links", {}) if isinstance(data, dict) else {}
    if op == "inertia":
        rigid = [k for k, v in links.items() if isinstance(v, dict) and "inertia" in v]
        if not rigid:
            return None
        name = rng.choice(rigid)
        value, certain = rng.choice(_INERTIAS)
        links[name]["inertia"] = value
        return Mutant(yaml.safe_dump(data, sort_keys=False), op, ("links", name, "inertia"),
                      certain)
    if op == "table":
        drivers = data.get("drivers") or {}
        if not isinstance(drivers, dict) or not drivers:
            return None
        name = rng.choice(sorted(drivers))
        drivers[name] = {"type": "table", "file": rng.choice(_TABLE_FILES)}
        return Mutant(yaml.safe_dump(data, sort_keys=False), op, ("drivers", name), True)
    frames = [(k, f) for k, v in links.items() if isinstance(v, dict)
              for f in (v.get("frames") or {})]
    if not frames:
        return None
    link, frame = rng.choice(frames)
    links[link]["frames"][frame]["z"] = rng.choice([[0, 0, 0], [0.0, 0.0, 0.0]])
    return Mutant(yaml.safe_dump(data, sort_keys=False), op, ("links", link, "frames", frame),
                  True)


_LOOP = b'SetFactory("OpenCASCADE");\nn = 10^12;\nFor i In {1:n}\n  x = i;\nEndFor\n'
_SELF_MESHED = (b'SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 1, 1, 1};\n'
                b"Mesh.MeshSizeMax = 0.002;\nMesh.MeshSizeMin = 0.002;\nMesh 3;\n")
_FINE_FIELD = (b'SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 0.1, 0.02, 0.02};\n'
               b'Field[1] = MathEval;\nField[1].F = "0.001";\nBackground Field = 1;\n')


def _meshing(data: dict, rng: random.Random) -> Mutant:
    """A link spec whose geometry meets one meshing guard (each refusal is certain): a .geo
    loop whose bound is computed (time limit), a script that meshes itself finely (memory
    budget), a size field finer than mesh_size (output budget), a CAD path that is a
    device, a folder or missing, a STEP file of garbage, a length beyond the recipes'
    range, a mesh_size far beyond the machine."""
    guard = rng.choice(["loop", "self_meshed", "fine_field", "cad_path", "cad_garbage",
                        "extent", "mesh_size"])
    geo = {"type": "solid", "recipe": "geo", "path": "link.geo", "mesh_size": 0.05,
           "order": 1}
    files: tuple[tuple[str, bytes], ...] = ()
    if guard == "loop":
        geo["time_limit"], files = 2, (("link.geo", _LOOP),)
    elif guard == "self_meshed":
        geo["memory_limit"], files = 0.1, (("link.geo", _SELF_MESHED),)
    elif guard == "fine_field":
        geo["memory_limit"], files = 0.2, (("link.geo", _FINE_FIELD),)
    elif guard == "cad_path":
        geo.update(recipe="step", path=rng.choice(["/dev/zero", "/", "missing.step"]))
    elif guard == "cad_garbage":
        junk = bytes(rng.randrange(256) for _ in range(rng.randrange(0, 4096)))
        geo.update(recipe="step", path="link.step")
        files = (("link.step", rng.choice([b"", b"ISO-10303-21;\n" + junk, junk])),)
    elif guard == "extent":
        geo = {"type": "solid", "recipe": "bar", "mesh_size": 0.01,
               "params": {"L": rng.choice([1e30, 1e5, -1.0e6]), "b": 0.02, "h": 0.01}}
    else:
        geo = {"type": "solid", "recipe": "bar", "mesh_size": rng.choice([1e-9, 1e-6]),
               "params": {"L": 0.4, "b": 0.02, "h": 0.01}}
    data["geometry"] = geo
    return Mutant(yaml.safe_dump(data, sort_keys=False), f"mesh/{guard}", ("geometry",), True,
                  files)


class _Timeout(Exception):
    pass


def _alarm(signum, frame):
    raise _Timeout


def check(mutant: Mutant, path: Path, kind: str, build_cache: Path | None) -> tuple[str, str]:
    """(outcome, detail) of one mutant written at ``path``; ``kind``: "workflow" or
    "link"; ``build_cache``: build rigid machines (their link cache) or None."""
    path.write_text(mutant.text, encoding="utf-8")
    for name, content in mutant.files:
        (path.parent / name).write_bytes(content)
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(TIME_LIMIT)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # numpy's stray terminal lines
            _load(mutant, path, kind, build_cache)
    except _Timeout:
        return "hang", f"{mutant.op} at {mutant.path}: over {TIME_LIMIT} s"
    except PipelineError as exc:
        msg = str(exc)
        if isinstance(exc, ConfigError) and not re.match(
                rf"^{re.escape(str(path))}(:\d+)?: ", msg):
            return "unclear", f"{mutant.op} at {mutant.path}: {msg[:300]}"
        return "clear", msg.splitlines()[0][:200]
    except Exception:  # noqa: BLE001 - what the user would see as a traceback
        return "traceback", f"{mutant.op} at {mutant.path}: {traceback.format_exc()[-800:]}"
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    if mutant.must_fail:
        return "silent", f"{mutant.op} at {mutant.path}: accepted"
    return "ok", ""


def _load(mutant: Mutant, path: Path, kind: str, build_cache: Path | None) -> None:
    """Load (and mesh or build) the mutant at ``path`` as the commands would."""
    from pipeline.workflow import build_machine, load_workflow
    from pipeline.workflow.link_spec import load_link_spec_lines
    from pipeline.workflow.run import build_cases, check_outputs

    if kind == "link":
        spec, lines = load_link_spec_lines(path)
        if mutant.op.startswith("mesh/"):  # mesh it, as pipeline reduce would first
            _mesh(spec, path, lines)
    else:
        wf = load_workflow(path)
        if build_cache is not None:  # as validate --build does
            base = build_machine(wf, build_cache)
            check_outputs(wf, base)
            build_cases(wf, base, build_cache)


def _mesh(spec, path: Path, lines: dict) -> None:
    """Mesh ``spec``'s geometry under its budget; an error at its line, as ``pipeline
    reduce`` reports it."""
    from pipeline.meshing import build_mesh
    from pipeline.workflow.link_build import link_request
    from pipeline.workflow.link_spec import locate

    try:
        request, _ = link_request(spec, path.parent)
        build_mesh(request.geometry, spec.name, budget=request.mesh_budget)
    except PipelineError as exc:
        raise type(exc)(locate(str(exc), spec, path, lines, ("geometry",))) from None


def run(bases: list[tuple[str, str, str, bool]], n: int, seed: int, folder: Path,
        cache: Path) -> dict[str, list[str]]:
    """Check ``n`` mutants of ``bases`` (name, text, kind, build); outcome -> details."""
    rng = random.Random(seed)
    out: dict[str, list[str]] = {}
    for k in range(n):
        name, text, kind, build = bases[k % len(bases)]
        mutant = mutate(text, rng, build, link=kind == "link")
        sub = folder / f"m{k}"
        sub.mkdir(parents=True, exist_ok=True)
        outcome, detail = check(mutant, sub / f"{name}.yaml", kind, cache if build else None)
        out.setdefault(outcome, []).append(f"{name} #{k}: {detail}")
    return out


def summary(out: dict[str, Any]) -> str:
    return ", ".join(f"{k}: {len(v)}" for k, v in sorted(out.items()))
