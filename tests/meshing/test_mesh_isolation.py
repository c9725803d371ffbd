"""Meshing runs in its own process with a wall-time, a memory and an output-size budget
(issue 26, item 5): gmsh cannot be interrupted in-process, so a .geo script whose loop
bound is an expression ran for ever, a script that meshed itself finely ate the machine's
memory, and an OCC crash took the whole run with it. Each case here uses real gmsh in a
real child process."""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest

from pipeline.core.errors import MeshError
from pipeline.meshing import MeshBudget, build_mesh
from pipeline.meshing.geometry import SolidGeometry

pytest.importorskip("gmsh")

BAR = {"L": 0.4, "b": 0.008, "h": 0.004}


def _geo(tmp_path, body: str):
    path = tmp_path / "link.geo"
    path.write_text('SetFactory("OpenCASCADE");\n' + body)
    return path


def test_the_isolated_mesh_equals_the_in_process_mesh():
    g = SolidGeometry("bar", BAR, 0.004, 2)
    a = build_mesh(g, "bar")
    b = build_mesh(g, "bar", isolate=False)
    np.testing.assert_array_equal(a.points, b.points)
    assert a.cells.keys() == b.cells.keys() and a.groups.keys() == b.groups.keys()
    for k in a.cells:
        np.testing.assert_array_equal(a.cells[k], b.cells[k])
    for k in a.groups:
        np.testing.assert_array_equal(a.groups[k], b.groups[k])
    for k in a.cad:
        np.testing.assert_array_equal(a.cad[k], b.cad[k])
    assert (a.kind, a.order, a.source) == (b.kind, b.order, b.source)


def test_a_geo_loop_with_an_expression_bound_is_stopped_at_the_time_limit(tmp_path):
    """The scan refuses literal loops over 1e6 passes; a bound computed by the script
    cannot be judged before it runs."""
    path = _geo(tmp_path, "n = 10^12;\nFor i In {1:n}\n  x = i;\nEndFor\n"
                          "Box(1) = {0, 0, 0, 0.1, 0.01, 0.01};\n")
    t0 = time.monotonic()
    with pytest.raises(MeshError, match=r"link 'spin': meshing was stopped after its time "
                                        r"limit of 2 s:.*geometry.time_limit"):
        build_mesh(SolidGeometry("geo", {}, 0.005, 1, path), "spin",
                   budget=MeshBudget(seconds=2.0))
    assert time.monotonic() - t0 < 30.0


def test_a_child_whose_last_words_fail_for_memory_names_the_budget():
    """Seen in a full run: the child ran out of memory in its own error handler (reading
    /proc) and ended with exit code 1 and a MemoryError traceback instead of a status."""
    from pipeline.meshing.budget import _no_result

    tail = ("; its last messages:            ^^^^^ |   File \"pipeline/core/resources.py\", "
            "line 17, in _kib_field |     for line in fh: | MemoryError")
    assert _no_result("link 'greedy'", 1, 2**30 // 10, 2**30, tail) == (
        "link 'greedy': meshing ran out of its memory budget of 0.1 GB: coarsen mesh_size, "
        "or raise geometry.memory_limit if the machine has more")
    # without a budget, or for another failure, the exit and the messages as they were
    assert _no_result("link 'x'", 1, None, 2**30, tail).startswith(
        "link 'x': the meshing process ended with exit code 1 without a result; its last")
    assert "SIGSEGV" in _no_result("link 'x'", -11, 2**30, 2**30, "")


def test_a_script_that_meshes_itself_beyond_the_memory_budget_is_stopped(tmp_path):
    """The script meshes a 1 m box at 2 mm itself (some 800 million tetrahedra) before the
    budget estimate can be asked; the memory limit stops it with one line."""
    path = _geo(tmp_path, "Box(1) = {0, 0, 0, 1, 1, 1};\nMesh.MeshSizeMax = 0.002;\n"
                          "Mesh.MeshSizeMin = 0.002;\nMesh 3;\n")
    with pytest.raises(MeshError, match=r"link 'greedy': meshing ran out of its memory "
                                        r"budget of 0.1 GB: .*geometry.memory_limit"):
        build_mesh(SolidGeometry("geo", {}, 0.5, 1, path), "greedy",
                   budget=MeshBudget(seconds=120.0, memory=0.1 * 2**30))


def test_a_mesh_beyond_the_output_budget_is_refused_with_its_size(tmp_path):
    """A script's own size field makes a mesh far finer than mesh_size promised: it fits in
    the meshing process but its reduction would not fit in the budget."""
    path = _geo(tmp_path, "Box(1) = {0, 0, 0, 0.1, 0.02, 0.02};\n"
                          "Field[1] = MathEval;\nField[1].F = \"0.001\";\n"
                          "Background Field = 1;\n")
    with pytest.raises(MeshError, match=r"link 'fine': the mesh has \d+ nodes .* its "
                                        r"reduction needs ~[\d.]+ GB, more than the memory "
                                        r"budget of 0\.2 GB"):
        build_mesh(SolidGeometry("geo", {}, 0.05, 1, path), "fine",
                   budget=MeshBudget(seconds=120.0, memory=0.2 * 2**30))


def test_a_meshing_process_that_dies_is_one_error_and_the_caller_lives(tmp_path):
    """A crash in gmsh or OCC (seen: SIGSEGV on damaged CAD) ends the child, not the run.
    The child is killed from outside while it loops."""
    path = _geo(tmp_path, "n = 10^12;\nFor i In {1:n}\n  x = i;\nEndFor\n")
    parent = os.getpid()

    def kill_child():
        for _ in range(200):
            time.sleep(0.1)
            kids = _children(parent)
            if kids:
                time.sleep(0.5)
                os.kill(kids[0], signal.SIGSEGV)
                return

    killer = threading.Thread(target=kill_child)
    killer.start()
    try:
        with pytest.raises(MeshError, match=r"link 'crash': the meshing process ended with "
                                            r"SIGSEGV"):
            build_mesh(SolidGeometry("geo", {}, 0.005, 1, path), "crash",
                       budget=MeshBudget(seconds=60.0))
    finally:
        killer.join()


def _children(pid: int) -> list[int]:
    """The meshing processes among ``pid``'s children (a test session has others: a
    multiprocessing resource tracker, which this test once killed instead)."""
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as fh:
            kids = [int(x) for x in fh.read().split()]
    except OSError:
        return []
    out = []
    for k in kids:
        try:
            with open(f"/proc/{k}/cmdline", "rb") as fh:
                if b"pipeline.meshing.mesh_child" in fh.read():
                    out.append(k)
        except OSError:
            continue
    return out


def test_errors_inside_the_child_keep_their_kind_and_message(tmp_path):
    from pipeline.core.errors import ConfigError

    with pytest.raises(ConfigError, match=r"link 'bar': params.colour: unknown parameter"):
        build_mesh(SolidGeometry("bar", {**BAR, "colour": 1.0}, 0.004, 2), "bar")
    with pytest.raises(MeshError, match="link 'void': geometry 'geo' has no volume"):
        build_mesh(SolidGeometry("geo", {}, 0.004, 2, _geo(tmp_path, "Point(1) = {0,0,0};\n")),
                   "void")


def test_a_link_spec_s_limits_reach_meshing_and_leave_its_cache_key_alone(tmp_path):
    """``geometry.time_limit`` / ``memory_limit`` bound the work, not the result: the
    artifact's input hash ignores them, and a memory limit too small for the mesh's
    estimate is refused before gmsh meshes."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from link_samples import write_bar

    from pipeline.workflow.link_build import input_hash, link_request, reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    spec = load_link_spec(write_bar(tmp_path, modes=2))
    text = (tmp_path / "bar.yaml").read_text().replace(
        "  order: 2\n", "  order: 2\n  time_limit: 30\n  memory_limit: 1.0e-4\n")
    (tmp_path / "tight.yaml").write_text(text)
    tight = load_link_spec(tmp_path / "tight.yaml")
    assert input_hash(spec, ()) == input_hash(tight, ())
    request, _ = link_request(tight, tmp_path)
    assert request.mesh_budget == MeshBudget(30.0, 1.0e-4 * 2**30)
    with pytest.raises(MeshError, match=r"link 'bar': mesh_size 0.01 m .* the memory budget "
                                        r"is 0.0001 GB \(geometry.memory_limit"):
        reduce_spec(tight, tmp_path, tmp_path / "links")
