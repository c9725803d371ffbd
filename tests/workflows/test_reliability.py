"""Nothing lost, nothing executed, every bad input one clear line (issue: reliability and
security). Each case was a failure of the code before: a folder renamed away, two cases
writing one file, a swap a kill could interrupt, a gmsh script running a command, a YAML
alias bomb."""

from __future__ import annotations

import json
import logging
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from test_workflow_run import FOURBAR, _write

from pipeline.core.atomic import folder_lock, replace_dir
from pipeline.core.errors import ConfigError, MeshError
from pipeline.meshing.geo_scan import check_geo_script
from pipeline.workflow import load_workflow, run_workflow
from pipeline.workflow.yaml_io import MAX_NODES, load_yaml

NO_NAME = FOURBAR.replace("name: fourbar\n", "")


def _keepsakes(out: Path) -> dict[str, str]:
    """Results of an earlier run and a link cache, to prove they survive."""
    files = {"links/lift_arm.npz": "cached reduction", "other/manifest.json": "{}"}
    for rel, text in files.items():
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text(text)
    return files


@pytest.mark.parametrize("stem", ["..", "...", ".hidden", "a b"])
def test_a_file_name_that_cannot_name_the_output_folder_is_refused(tmp_path, stem):
    path = tmp_path / f"{stem}.yaml"
    path.write_text(NO_NAME)
    out = tmp_path / "output"
    kept = _keepsakes(out)
    with pytest.raises(ConfigError, match="cannot name the output folder") as exc:
        run_workflow(path, out_root=out)
    assert str(path) in str(exc.value) and "name:" in str(exc.value)
    assert {rel: (out / rel).read_text() for rel in kept} == kept
    assert sorted(p.name for p in out.iterdir()) == ["links", "other"]


@pytest.mark.parametrize("name", ["links", "bench"])
def test_a_run_cannot_take_a_folder_the_pipeline_keeps(tmp_path, name):
    out = tmp_path / "output"
    kept = _keepsakes(out)
    with pytest.raises(ConfigError, match="keeps in output/"):
        run_workflow(_write(tmp_path), out_root=out, sets=[f"name={name}"])
    assert {rel: (out / rel).read_text() for rel in kept} == kept


def test_a_run_cannot_replace_a_custom_link_cache(tmp_path):
    out = tmp_path / "output"
    kept = _keepsakes(out)
    with pytest.raises(ConfigError, match="reduced-link cache"):
        run_workflow(_write(tmp_path), out_root=out, cache_dir=out / "fourbar" / "cache")
    assert {rel: (out / rel).read_text() for rel in kept} == kept


@pytest.mark.parametrize("old, new, where", [
    ("{label: slow, set: {}}", "{label: slow run, set: {}}\n      - {label: slow_run, set: {}}",
     "analyses[0].cases[1].label"),
    ("{label: slow, set: {}}", "{label: Fast, set: {}}", "analyses[0].cases[1].label"),
    ("{label: slow, set: {}}", "{label: fast, set: {}}", "analyses[0].cases"),
])
def test_two_outputs_that_would_write_one_file_are_refused_at_load(tmp_path, old, new, where):
    text = FOURBAR.replace(old, new)
    assert text != FOURBAR
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        load_workflow(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}:") and where in msg, msg


def test_a_convergence_study_named_like_a_case_export_is_refused(tmp_path):
    text = FOURBAR + "  convergence:\n    - {name: turn_slow, analysis: turn, " \
                     "series: [q:JD.theta]}\n"
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError, match="turn_slow.csv") as exc:
        load_workflow(path)
    assert "outputs.convergence[0].name" in str(exc.value)


SWAPPER = textwrap.dedent("""
    import json, os, sys
    from pathlib import Path
    from pipeline.core.atomic import replace_dir
    out = Path(sys.argv[1]); final = out / "run"; tag = sys.argv[2]
    for k in range(int(sys.argv[3])):
        tmp = out / f".run.partial-{os.getpid()}"
        tmp.mkdir()
        for i in range(20):
            (tmp / f"f{i}.txt").write_text(f"{tag}{k}")
        (tmp / "manifest.json").write_text(json.dumps({"tag": tag, "k": k, "files": 20}))
        replace_dir(tmp, final)
""")


def _complete(final: Path) -> bool:
    man = json.loads((final / "manifest.json").read_text())
    texts = {(final / f"f{i}.txt").read_text() for i in range(man["files"])}
    return texts == {f"{man['tag']}{man['k']}"}


@pytest.mark.slow  # budget of the default run: .ci/run's slow run has it
def test_a_kill_at_any_instant_of_the_swap_leaves_old_or_new_results(tmp_path):
    script = tmp_path / "swap.py"
    script.write_text(SWAPPER)
    subprocess.run([sys.executable, str(script), str(tmp_path), "first", "1"], check=True)
    delays = [0.05 + 0.013 * k for k in range(12)]
    for delay in delays:
        p = subprocess.Popen([sys.executable, str(script), str(tmp_path), "next", "100000"])
        time.sleep(delay + 0.3)  # the interpreter's start, then somewhere in the loop
        p.send_signal(signal.SIGKILL)
        p.wait()
        assert _complete(tmp_path / "run")


def test_concurrent_swaps_never_lose_the_folder(tmp_path):
    script = tmp_path / "swap.py"
    script.write_text(SWAPPER)
    procs = [subprocess.Popen([sys.executable, str(script), str(tmp_path), tag, "60"],
                              stderr=subprocess.PIPE, text=True) for tag in ("a", "b", "c")]
    errors = [p.communicate()[1] for p in procs]
    assert all(p.returncode == 0 for p in procs), errors
    assert _complete(tmp_path / "run")
    assert not list(tmp_path.glob(".run.*"))  # nothing left behind


def test_replace_dir_into_a_new_place_and_over_an_old_one(tmp_path):
    a, final = tmp_path / "a", tmp_path / "final"
    a.mkdir()
    (a / "x").write_text("1")
    replace_dir(a, final)
    assert (final / "x").read_text() == "1" and not a.exists()
    a.mkdir()
    (a / "y").write_text("2")
    replace_dir(a, final)
    assert sorted(p.name for p in final.iterdir()) == ["y"] and not a.exists()


def test_a_second_run_of_one_workflow_is_refused_while_the_first_runs(tmp_path):
    out = tmp_path / "output"
    with folder_lock(out, "fourbar"), pytest.raises(ConfigError, match="another run"):
        run_workflow(_write(tmp_path), out_root=out, cache_dir=tmp_path / "links",
                     outputs=False)
    assert not list(out.glob(".fourbar*"))


def test_temporaries_of_killed_runs_are_removed_by_the_next_run(tmp_path):
    out = tmp_path / "output"
    for name in (".fourbar.partial-999999", ".fourbar.old-999998", ".other.partial-1"):
        (out / name).mkdir(parents=True)
        (out / name / "big.npz").write_bytes(b"0" * 1000)
    run_workflow(_write(tmp_path), out_root=out, cache_dir=tmp_path / "links", outputs=False)
    assert sorted(p.name for p in out.iterdir()) == [".other.partial-1", "fourbar"]


# --- gmsh scripts -----------------------------------------------------------------------------

BOX = 'SetFactory("OpenCASCADE");\nBox(1) = {0, 0, 0, 1, 0.1, 0.1};\n'


@pytest.mark.parametrize("line", [
    'SystemCall "touch {marker}";',
    'System "touch {marker}";',
    'NonBlockingSystemCall "touch {marker}";',
    'Include "other.geo";',
    'Merge "other.geo";',
    'Save "{marker}";',
    'CreateDir "{marker}";',
    'Printf("%g", 1) > "{marker}";',
    'Printf("%g", 1) >> "{marker}";',
    'OnelabRun("x", "touch {marker}");',
    'Solver.Executable0 = "touch";',
    "Exit;",
    'Plugin(CutPlane).Run;',
])
def test_gmsh_commands_that_run_or_write_are_refused_before_gmsh_sees_them(tmp_path, line):
    marker = tmp_path / "ran"
    geo = tmp_path / "part.geo"
    geo.write_text(BOX + "// a comment: SystemCall in a comment is fine\n"
                   + line.format(marker=marker) + "\n")
    with pytest.raises(MeshError) as exc:
        check_geo_script(geo, "link arm")
    assert str(exc.value).startswith(f"{geo}:4: ") and "(link arm)" in str(exc.value)
    assert not marker.exists()


def test_an_ordinary_geo_script_passes_the_scan(tmp_path):
    geo = tmp_path / "part.geo"
    geo.write_text(BOX + 'a = 2; b = 1;\nPrintf("%g", a > b ? 1 : 0);\n'
                   '/* Exit; Include "x"; */\nS = "SystemCall";\n'
                   'Physical Volume("body") = {1};\n')
    check_geo_script(geo)


def test_a_link_spec_with_a_forbidden_geo_command_is_refused_on_reduce(tmp_path):
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    marker = tmp_path / "ran"
    (tmp_path / "part.geo").write_text(BOX + f'SystemCall "touch {marker}";\n')
    spec = tmp_path / "part.yaml"
    spec.write_text(textwrap.dedent("""\
        name: part
        geometry: {type: solid, recipe: geo, path: part.geo, mesh_size: 0.05}
        material: {E: 2.1e11, nu: 0.3, rho: 7850}
        interfaces:
          - {name: root, selector: {type: plane, point: [0, 0, 0], normal: [1, 0, 0]}, origin: [0, 0, 0], z_axis: [1, 0, 0]}
        reference: root
        modes: {count: 2}
        """))
    with pytest.raises(MeshError, match="SystemCall"):
        reduce_spec(load_link_spec(spec), tmp_path, tmp_path / "links")
    assert not marker.exists()


# --- YAML -------------------------------------------------------------------------------------

def _bomb(levels: int = 12) -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    for k in range(1, levels):
        refs = ", ".join([f"*a{k - 1}"] * 9)
        lines.append(f"a{k}: &a{k} [{refs}]")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("text, line, expect", [
    (_bomb(), 6, f"a5: more than {MAX_NODES} values"),
    ("a: &a [1, *a]\n", 1, "nested deeper"),
    ("a: &a {b: *a}\n", 1, "nested deeper"),
    ("a:\n" + "".join("  " * (k + 1) + f"k{k}:\n" for k in range(80)) + "  " * 81 + "v: 1\n",
     None, "nested deeper"),
    ("x: 1\n? [1, 2]\n: 3\n", 2, "keys must be plain"),
    ("x: 1\ny: !!python/object/apply:os.system ['touch ran']\n", 2, "not allowed"),
    ("x: !foo 3\n", 1, "not allowed"),
    ("x: !!binary aGVsbG8=\n", 1, "not allowed"),
    ("x: !!set {a, b}\n", 1, "not allowed"),
    ("x: 1\nx: 2\n", 2, "duplicate key"),
])
def test_yaml_beyond_plain_data_or_the_limits_is_one_clear_error(tmp_path, text, line, expect):
    path = tmp_path / "w.yaml"
    path.write_text(text)  # the 12-level bomb expands to 2.8e11 values: it must stop early
    with pytest.raises(ConfigError) as exc:
        load_yaml(path)
    msg = str(exc.value)
    assert expect in msg and msg.startswith(f"{path}:" if line is None else f"{path}:{line}:")
    assert not (tmp_path / "ran").exists()


def test_deep_flow_nesting_that_overflows_the_parser_is_one_clear_error(tmp_path):
    path = tmp_path / "w.yaml"
    path.write_text("x: " + "[" * 3000 + "]" * 3000 + "\n")
    with pytest.raises(ConfigError, match=f"{path}"):
        load_yaml(path)


def test_non_utf8_bytes_name_the_line(tmp_path):
    path = tmp_path / "w.yaml"
    path.write_bytes(b"name: a\ndescription: caf\xe9\n")
    with pytest.raises(ConfigError, match=rf"{path}:2: not UTF-8"):
        load_yaml(path)


def test_a_huge_file_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "w.yaml"
    with open(path, "wb") as fh:
        fh.write(b"x: [")
        fh.seek(9 * 2**20)
        fh.write(b"1]\n")
    with pytest.raises(ConfigError, match="limited to 8 MB"):
        load_yaml(path)


def test_dates_stay_text_and_numbers_keep_their_types(tmp_path):
    path = tmp_path / "w.yaml"
    path.write_text("d: 2026-11-24\nf: 4.8e5\ni: 3\nb: true\nn: null\ns: 'x'\n")
    data, lines = load_yaml(path)
    assert data == {"d": "2026-11-24", "f": 480000.0, "i": 3, "b": True, "n": None, "s": "x"}
    assert lines[("i",)] == 3


def test_the_cli_prints_one_line_for_a_yaml_bomb(tmp_path):
    path = tmp_path / "bomb.yaml"
    path.write_text(_bomb())
    r = subprocess.run([sys.executable, "-m", "pipeline", "validate", str(path)],
                       capture_output=True, text=True, check=False,
                       env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().count("\n") == 0 and str(path) in r.stderr


# --- one error path ---------------------------------------------------------------------------

def test_kinematic_errors_pickle_with_their_message_and_figures():
    import pickle

    import numpy as np

    from pipeline.kinematics.failures import ClosureError, SingularConfigurationError

    e = ClosureError("loop L1 does not close", "L1", "JC", np.ones(6), np.zeros(4))
    f = pickle.loads(pickle.dumps(e))
    assert str(f) == str(e) and f.loop == "L1" and np.array_equal(f.residual, e.residual)
    e = SingularConfigurationError("singular", ("J1",), np.zeros(2), 0.5, {"J1.theta": 1.0})
    f = pickle.loads(pickle.dumps(e))
    assert str(f) == "singular" and f.t == 0.5 and f.drivers == {"J1.theta": 1.0}


def test_an_output_path_that_is_a_file_is_one_line(tmp_path):
    blocker = tmp_path / "output"
    blocker.write_text("not a folder")
    r = subprocess.run([sys.executable, "-m", "pipeline", "run", str(_write(tmp_path)),
                        "--out", str(blocker)], capture_output=True, text=True, check=False)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = r.stderr.strip().splitlines()[-1:]
    assert line.startswith("error: ") and str(blocker) in line


def test_an_environment_error_names_the_file_and_the_reason():
    import errno

    from pipeline.cli import error_line

    code, line = error_line(OSError(errno.ENOSPC, "No space left on device", "out/a.csv"))
    assert code == 2 and line == "out/a.csv: No space left on device"
    code, line = error_line(OSError(errno.EROFS, "Read-only file system", "out"))
    assert code == 2 and line == "out: Read-only file system"
    assert error_line(MemoryError())[0] == 2


def test_an_internal_error_is_one_line_unless_debug(tmp_path, monkeypatch, capsys):
    from pipeline import cli
    from pipeline.commands import validate

    def broken(args):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr(validate, "run", broken)
    assert cli.main(["validate", str(_write(tmp_path))]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "internal error (ZeroDivisionError" in err
    assert "--debug" in err
    with pytest.raises(ZeroDivisionError):
        cli.main(["--debug", "validate", str(_write(tmp_path))])


def test_an_error_in_a_worker_arrives_as_the_original_one_line_error(tmp_path):
    """An analysis' own initial values that the loops cannot honour are found when the
    analysis starts, in its worker process: the error arrives as raised there, one line."""
    from test_workflow_trust import FREE

    text = FREE.replace("    t_end: 0.5\n    outputs: 11", "    t_end: 0.5\n    outputs: 11\n"
                        "    initial: {velocities: {JA.theta: 4.0, JD.theta: 9.0}}\n"
                        "    cases:\n      - {label: a, set: {}}\n      - {label: b, set: {}}")
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        run_workflow(path, out_root=tmp_path / "out", cache_dir=tmp_path / "links",
                     outputs=False, workers=2)
    msg = str(exc.value)
    assert "Traceback" not in msg and "\n" not in msg
    assert msg.startswith(f"{path}:") and "analyses[0].initial.velocities" in msg
    assert not (tmp_path / "out" / "fourbar").exists()


# --- numbers ----------------------------------------------------------------------------------

@pytest.mark.parametrize("old, new, path_text, expect", [
    ("    t_end: 1.0", "    t_end: true", "analyses[0].t_end", "valid number"),
    ("    t_end: 1.0", "    t_end: 1e999", "analyses[0].t_end", "finite number"),
    ("    t_end: 1.0", "    t_end: .nan", "analyses[0].t_end", "finite number"),
    ("    t_end: 1.0", "    t_end: '1.0'", "analyses[0].t_end", "valid number"),
    ("    outputs: 73", "    outputs: 2000000000", "analyses[0].outputs", "less than or equal"),
    ("    outputs: 73", "    outputs: true", "analyses[0].outputs", "valid integer"),
    ("    mass: 1.0", "    mass: .inf", "links.crank", "finite number"),
    ("[0, -9.81, 0]", "[0, true, 0]", "gravity[1]", "valid number"),
])
def test_numbers_must_be_finite_numbers(tmp_path, old, new, path_text, expect):
    text = FOURBAR.replace(old, new, 1)
    assert text != FOURBAR
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        load_workflow(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}:") and path_text in msg and expect in msg, msg


@pytest.mark.parametrize("extra, expect", [
    ("    max_step: 1.0e-7\n", "max_step: 1e-07 s needs at least 5e+06 steps"),
    ("    method: generalized_alpha\n    step: 1.0e-8\n", "step: 1e-08 s needs at least 5e+07"),
])
def test_a_step_beyond_the_step_budget_is_refused_up_front(tmp_path, extra, expect):
    from test_workflow_trust import FREE

    text = FREE.replace("    outputs: 11\n", "    outputs: 11\n" + extra)
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        load_workflow(path)
    assert "analyses[0]: " + expect in str(exc.value)


# --- physics of the inputs --------------------------------------------------------------------

@pytest.mark.parametrize("inertia, expect", [
    ("[-0.1, 2.3, 2.3, 0, 0, 0]", "negative principal moment"),
    ("[0.003, 2.3, 2.3, 3.0, 0, 0]", "negative principal moment"),
    ("[[1, 0.1, 0], [0.2, 1, 0], [0, 0, 1]]", "not symmetric"),
    ("[0.003, 2.3, 2.3, 0, 0, 1.0e+308]", "negative principal moment"),  # overflowed numpy
])
def test_a_rigid_inertia_no_motion_can_have_is_refused(tmp_path, inertia, expect):
    import warnings

    text = FOURBAR.replace("inertia: [0.003, 2.3, 2.3, 0, 0, 0]", f"inertia: {inertia}")
    assert text != FOURBAR
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError, match=expect) as exc, warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        load_workflow(path)
    assert str(exc.value).startswith(f"{path}:") and "links.coupler" in str(exc.value)


@pytest.mark.parametrize("inertia", ["[1.0, 2.0, 3.0, 0, 0, 0]", "[0, 0, 0, 0, 0, 0]",
                                     "[1.0, 1.0, 3.0, 0, 0, 0]", "[0, 2.3, 2.3, 0, 0, 0]"])
def test_thin_plates_rods_point_masses_and_reflected_inertias_load(tmp_path, inertia):
    text = FOURBAR.replace("inertia: [0.003, 2.3, 2.3, 0, 0, 0]", f"inertia: {inertia}")
    load_workflow(_write(tmp_path, text))


# a four-bar swinging under gravity: thin-rod coupler and rocker (no moment about their
# axes), a crank carrying a flywheel's reflected inertia about its pin (breaks the
# triangle inequality); crank 1, coupler 3, rocker 2, ground 3.5 m
def _swing() -> str:
    """The free four-bar of test_workflow_trust swinging for 1 s from rest at JA = 1 rad:
    thin-rod coupler and rocker (no moment about their axes), a crank carrying a flywheel's
    reflected inertia about its pin (breaks the triangle inequality); crank 1, coupler 3,
    rocker 2, ground 3.5 m."""
    from test_workflow_trust import FREE

    return FREE.replace("inertia: [0.001, 0.1, 0.1, 0, 0, 0]",
                        "inertia: [0.02, 0.02, 1.0066, 0, 0, 0]") \
        .replace("inertia: [0.003, 2.3, 2.3, 0, 0, 0]", "inertia: [0, 2.25, 2.25, 0, 0, 0]") \
        .replace("inertia: [0.002, 0.7, 0.7, 0, 0, 0]",
                 "inertia: [0, 0.6666666666666666, 0.6666666666666666, 0, 0, 0]") \
        .replace("    t_end: 0.5\n    outputs: 11", "    t_end: 1.0\n    outputs: 51\n"
                 "    rtol: 1.0e-10\n    atol: 1.0e-12") + \
        "initial:\n  coordinates: {JA.theta: 1.0}\n"


def _four_bar_swing(t):
    """The same four-bar in its crank angle alone, from the closed-form kinematics
    (tests/kinematics/closed_form.py) by virtual power: sum over the bars of
    (m a_c + m g) . dc/dtheta2 + I alpha dphi/dtheta2 = 0, integrated by scipy."""
    from closed_form import four_bar as fb
    from scipy.integrate import solve_ivp

    a, b, c, d, g = 1.0, 3.0, 2.0, 3.5, 9.81
    m, inertia = (1.0, 3.0, 2.0), (1.0066, 2.25, 2.0 / 3.0)

    def kin(t2, w2, al2):
        """[(com acceleration (2,), angular acceleration)] of crank, coupler, rocker."""
        s = fb(t2, w2, al2, a, b, c, d)
        e = lambda th: np.array([np.cos(th), np.sin(th)])  # noqa: E731
        n = lambda th: np.array([-np.sin(th), np.cos(th)])  # noqa: E731
        crank = 0.5 * a * (al2 * n(t2) - w2 ** 2 * e(t2))
        coupler = a * (al2 * n(t2) - w2 ** 2 * e(t2)) + 0.5 * b * (
            s.theta3_dd * n(s.theta3) - s.theta3_d ** 2 * e(s.theta3))
        rocker = 0.5 * c * (s.theta4_dd * n(s.theta4) - s.theta4_d ** 2 * e(s.theta4))
        return [(crank, al2), (coupler, s.theta3_dd), (rocker, s.theta4_dd)]

    def rhs(_, y):
        t2, w2 = y
        s1 = fb(t2, 1.0, 0.0, a, b, c, d)  # velocities per unit crank rate
        jc = [0.5 * a * np.array([-np.sin(t2), np.cos(t2)]),
              a * np.array([-np.sin(t2), np.cos(t2)]) + 0.5 * b * s1.theta3_d * np.array(
                  [-np.sin(s1.theta3), np.cos(s1.theta3)]),
              0.5 * c * s1.theta4_d * np.array([-np.sin(s1.theta4), np.cos(s1.theta4)])]
        jphi = [1.0, float(s1.theta3_d), float(s1.theta4_d)]
        bias = kin(t2, w2, 0.0)
        mass = sum(mi * jci @ jci + ii * jp ** 2 for mi, ii, jci, jp in zip(m, inertia, jc, jphi))
        force = sum(-mi * (ac + np.array([0.0, g])) @ jci - ii * al * jp
                    for mi, ii, jci, jp, (ac, al) in zip(m, inertia, jc, jphi, bias))
        return [w2, force / mass]

    sol = solve_ivp(rhs, (t[0], t[-1]), [1.0, 0.0], t_eval=t, method="DOP853", rtol=1e-12,
                    atol=1e-12)
    return sol.y[0]


def test_thin_rods_and_a_reflected_inertia_run_and_match_minimal_coordinates(tmp_path, caplog):
    """Issue 26, seen 2: thin rods without axial inertia and a flywheel's reflected inertia
    were refused ("not positive definite", "triangle inequality"). The joints never turn
    them about the axes that lack inertia, so the machine has inertia for every motion it
    allows: both load and run, and the crank angle equals a hand-written one-degree-of-
    freedom model within 1e-7 rad over 1 s."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))
    path = _write(tmp_path, _swing())
    with caplog.at_level(logging.INFO, logger="pipeline.workflow.build"):
        res = run_workflow(path, out_root=tmp_path / "out", cache_dir=tmp_path / "links",
                           outputs=False)
    assert any("links.crank.inertia" in m and "triangle inequality" in m and "accepted" in m
               for m in caplog.messages)
    (r,) = res.results["turn"]
    assert r.verdict == "ok", r.warnings
    ref = _four_bar_swing(r.t)
    got = r.q[:, list(r.coordinates).index("JA.theta")]
    assert np.ptp(ref) > 0.5  # it swings
    np.testing.assert_allclose(got, ref, atol=1e-7)


def test_a_motion_without_inertia_is_refused_at_the_build_naming_it(tmp_path):
    """A thin pin (no moment about its axis, its centre on that axis) on a revolute that
    spins it about its own axis: the machine has no inertia for that motion, and the build
    says which coordinate and which link, at the link's inertia line."""
    text = _swing().replace("{name: JD, type: revolute, parent: ground.D, child: rocker.D, "
                            "initial: [1.9]}",
                            "{name: JD, type: revolute, parent: ground.D, child: rocker.D, "
                            "initial: [1.9]}\n  - {name: SPIN, type: revolute, "
                            "parent: rocker.C, child: pin.A}")
    text = text.replace("  rocker:\n", "  pin:\n    type: rigid\n    mass: 0.5\n"
                        "    com: [0, 0, 0]\n    inertia: [0, 0.001, 0.001, 0, 0, 0]\n"
                        "    frames: {A: {origin: [0, 0, 0], z: [1, 0, 0]}}\n  rocker:\n")
    path = _write(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        run_workflow(path, out_root=tmp_path / "out", cache_dir=tmp_path / "links",
                     outputs=False)
    msg = str(exc.value)
    assert "no inertia for a motion its joints allow" in msg and "SPIN.theta" in msg
    assert "links.pin.inertia" in msg and "\n" not in msg


# --- partial results --------------------------------------------------------------------------

def test_a_failed_analysis_keeps_the_others_and_skips_its_outputs_with_a_note(tmp_path):
    """A static start that cannot converge (a 1e16 N m/rad spring, as reported) used to
    discard the whole run (KeyError in the CSV export, argmin of an empty sequence in the
    render); now the other analysis' results are written and the manifest says why the
    rest is missing."""
    from test_workflow_trust import FREE

    # the dynamic run implicit and short: the spring makes it very stiff
    text = FREE.replace("    t_end: 0.5\n    outputs: 11", "    t_end: 2.0e-3\n    outputs: 3\n"
                        "    method: generalized_alpha\n    step: 1.0e-3\n"
                        "  - name: modes\n    type: linearised\n    start: static") + """\
forces:
  - {name: s, type: joint_spring_damper, coordinate: JA.theta, stiffness: 1.0e16}
"""
    text = text.replace("    - {name: rocker, analysis: turn, series: [q:JD.theta]}",
                        "    - {name: rocker, analysis: turn, series: [q:JD.theta]}\n"
                        "    - {name: spectrum, analysis: modes, series: [frequency]}\n"
                        "  renders:\n    - {name: pic, analysis: modes}")
    res = run_workflow(_write(tmp_path, text), out_root=tmp_path / "out",
                       cache_dir=tmp_path / "links")
    man = json.loads((res.out_dir / "manifest.json").read_text())
    assert man["status"] == "partial"
    assert "turn.csv" in man["files"] and "rocker.png" in man["files"]
    assert (res.out_dir / "turn.csv").exists()
    notes = "\n".join(man["skipped_outputs"])
    assert "exports: no results in analysis 'modes'" in notes
    assert "plot 'spectrum'" in notes and "render 'pic'" in notes
    assert "static start" in notes  # the reason, from the analysis' message


# --- checked before anything runs -------------------------------------------------------------

@pytest.mark.parametrize("old, new, where", [
    ("    - {name: rocker, analysis: turn, series: [q:JD.theta]}",
     "    - {name: rocker, analysis: turn, series: [q:JD.theta], cases: [slow, fsat]}",
     "outputs.plots[0].cases"),
    ("    - {name: rocker, analysis: turn, series: [q:JD.theta]}",
     ("    - {name: rocker, analysis: turn, series: [q:JD.theta]}\n"
      "  renders:\n    - {name: pic, analysis: turn, case: sloww}"), "outputs.renders[0].case"),
    ("    - {name: rocker, analysis: turn, series: [q:JD.theta]}",
     ("    - {name: rocker, analysis: turn, series: [q:JD.theta]}\n"
      "  renders:\n    - {name: pic, analysis: turn, links: [couplr]}"),
     "outputs.renders[0].links"),
])
def test_case_names_in_outputs_are_checked_at_load(tmp_path, old, new, where):
    path = _write(tmp_path, FOURBAR.replace(old, new))
    with pytest.raises(ConfigError) as exc:
        load_workflow(path)
    assert str(exc.value).startswith(f"{path}:") and where in str(exc.value)


@pytest.mark.parametrize("marker, expect", [("coupler.X", "frames of coupler"),
                                            ("couplr.C", "known links")])
def test_a_marker_typo_is_found_before_the_analyses_run(tmp_path, marker, expect):
    path = _write(tmp_path, FOURBAR.replace("markers: [coupler.C]", f"markers: [{marker}]"))
    r = subprocess.run([sys.executable, "-m", "pipeline", "validate", str(path), "--build"],
                       capture_output=True, text=True, check=False)
    assert r.returncode == 2, r.stderr
    assert "analyses[0].markers[0]" in r.stderr and expect in r.stderr
    with pytest.raises(ConfigError, match="markers"):
        run_workflow(path, out_root=tmp_path / "out", cache_dir=tmp_path / "links")
    assert not (tmp_path / "out" / "fourbar").exists()


def test_what_the_fuzzer_found_stays_fixed(tmp_path):
    """A boolean accepted as the tetrahedra's order (True == 1), and mass properties
    that overflow to inf accepted silently."""
    from pipeline.workflow.build import build_machine
    from pipeline.workflow.link_spec import load_link_spec

    spec = (Path(__file__).resolve().parents[2] / "meshes" / "al_bar.yaml").read_text()
    path = tmp_path / "al_bar.yaml"
    path.write_text(spec.replace("  order: 2", "  order: true"))
    with pytest.raises(ConfigError, match="geometry.order"):
        load_link_spec(path)
    wf = load_workflow(_write(tmp_path, FOURBAR.replace("    mass: 3.0", "    mass: 1.0e+308")))
    with pytest.raises(ConfigError, match="overflow") as exc:
        build_machine(wf, tmp_path / "links")
    assert str(exc.value).startswith(str(wf.path)) and "links.coupler" in str(exc.value)


@pytest.mark.parametrize("value", ["oops", "true", "[1, 2]"])
def test_a_bad_case_override_is_found_before_any_analysis_runs(tmp_path, value):
    text = FOURBAR.replace("drivers.JA.theta.rate: 12.566370614359172",
                           f"drivers.JA.theta.rate: {value}")
    path = _write(tmp_path, text)
    calls = []
    import pipeline.workflow.run as run_mod

    real = run_mod.run_analysis
    run_mod.run_analysis = lambda *a, **k: calls.append(a) or real(*a, **k)
    try:
        with pytest.raises(ConfigError) as exc:
            run_workflow(path, out_root=tmp_path / "out", cache_dir=tmp_path / "links")
    finally:
        run_mod.run_analysis = real
    msg = str(exc.value)
    assert msg.startswith(f"{path}") and "fast" in msg and "rate" in msg, msg
    assert not calls  # refused before the first analysis


def test_a_bad_spec_override_is_blamed_on_its_own_line(tmp_path):
    """It was reported against a valid line of the link spec file."""
    from pipeline.workflow.build import build_machine

    root = Path(__file__).resolve().parents[2]
    text = (root / "workflows" / "double_pendulum.yaml").read_text()
    assert "spec: ../meshes/pendulum_bar.yaml\n    modes: 3\n" in text  # the upper bar first
    text = text.replace("spec: ../meshes/pendulum_bar.yaml\n    modes: 3\n",
                        f"spec: {root}/meshes/pendulum_bar.yaml\n"
                        "    spec_overrides: {geometry.mesh_size: -1.0}\n"
                        "    modes: 3\n", 1)
    path = tmp_path / "dp.yaml"
    path.write_text(text)
    line = text.splitlines().index("    spec_overrides: {geometry.mesh_size: -1.0}") + 1
    with pytest.raises(ConfigError) as exc:
        build_machine(load_workflow(path), tmp_path / "links")
    msg = str(exc.value)
    assert msg.startswith(f"{path}:{line}: links.upper.spec_overrides.geometry.mesh_size: "), msg
    assert "greater than 0" in msg


def test_pipeline_reduce_names_the_spec_line_of_a_failing_interface(tmp_path):
    root = Path(__file__).resolve().parents[2]
    text = (root / "meshes" / "al_bar.yaml").read_text()
    text = text.replace("name: end_xL", "name: end_x9").replace("mesh_size: 0.00205",
                                                                "mesh_size: 0.01")
    spec = tmp_path / "bar.yaml"
    spec.write_text(text)
    line = text.splitlines().index("    selector: {type: group, name: end_x9}")  # 1-based item
    r = subprocess.run([sys.executable, "-m", "pipeline", "reduce", str(spec), "--out",
                        str(tmp_path / "links")], capture_output=True, text=True, check=False)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.startswith(f"error: {spec}:{line}: interfaces[1]: "), r.stderr
    assert "end_x9" in r.stderr


def test_a_case_lost_to_the_cluster_is_a_failed_result_naming_the_cause(tmp_path, caplog):
    """A worker killed mid-run used to throw away every case; the one case runner hands
    each case over as it arrives (tests/core/test_cases.py kills a real worker), and a lost
    case becomes a failed, empty result saying why, while a case's own bad input is raised
    as it was raised in the worker."""
    from pipeline.core.cases import CaseLost
    from pipeline.workflow.build import build_machine
    from pipeline.workflow.run import case_outcome

    wf = load_workflow(_write(tmp_path))
    base = build_machine(wf, tmp_path / "links")
    a = wf.spec.analyses[0]
    why = "its worker process died (killed, or out of memory) before the case finished"
    with caplog.at_level(logging.WARNING, logger="pipeline.workflow.run"):
        fast = case_outcome(wf, base, a, "fast", None, CaseLost(why))
    assert not fast.success and fast.case == "fast" and fast.verdict == "partial"
    assert fast.message == why and len(fast.t) == 0 and fast.q.shape == (0, base.mechanism.n)
    assert "analysis 'turn' case 'fast': its worker process died" in caplog.text
    bad = ConfigError(f"{wf.path}:3: analyses[0].t_end: expected a number")
    with pytest.raises(ConfigError) as exc:
        case_outcome(wf, base, a, "slow", None, bad)
    assert exc.value is bad
    assert case_outcome(wf, base, a, "slow", "the result", None) == "the result"


def test_task_table_shows_each_case_state_and_seconds():
    from rich.console import Console

    from pipeline.core.progress import task_table

    console = Console(record=True, width=60, color_system=None)
    console.print(task_table([("swing / rigid", "ok", 12.34), ("swing / 3 modes", "running",
                                                                  3.0),
                              ("swing / 6 modes", "queued", None)]))
    lines = console.export_text().splitlines()
    assert lines[0].split() == ["case", "state", "s"]
    assert lines[1].split() == ["swing", "/", "rigid", "ok", "12.3"]
    assert lines[2].split() == ["swing", "/", "3", "modes", "running", "3.0"]
    assert lines[3].split() == ["swing", "/", "6", "modes", "queued"]


def test_set_values_are_plain_data_with_the_same_limits(tmp_path):
    from pipeline.workflow.overrides import parse_assignment

    assert parse_assignment("analyses.turn.t_end=4.8e5") == ("analyses.turn.t_end", 480000.0)
    assert parse_assignment("name=x") == ("name", "x")
    with pytest.raises(ConfigError, match="not allowed"):
        parse_assignment("name=!!python/object/apply:os.system ['touch ran']")
    with pytest.raises(ConfigError, match="more than"):
        parse_assignment("x=" + _bomb().replace("\n", ", ").replace("a0:", "{a0:")
                         .rstrip(", ") + "}")
    assert not (tmp_path / "ran").exists()


def test_a_dynamic_analysis_has_step_and_wall_budgets_by_default(tmp_path):
    from test_workflow_trust import FREE

    wf = load_workflow(_write(tmp_path, FREE))
    a = wf.spec.analyses[0]
    assert a.max_steps == 1_000_000 and a.max_wall == 3600.0
    wf = load_workflow(_write(tmp_path, FREE.replace("    outputs: 11", "    outputs: 11\n"
                                                     "    max_wall: null")))
    assert wf.spec.analyses[0].max_wall is None


def test_set_creates_missing_mappings_and_the_schema_names_a_misspelt_key(tmp_path):
    path = _write(tmp_path, FOURBAR)
    wf = load_workflow(path, sets=["links.crank.shape.type=box",
                                   "links.crank.shape.size=[1.0, 0.05, 0.05]"])
    assert wf.spec.links["crank"].shape.size == [1.0, 0.05, 0.05]
    with pytest.raises(ConfigError, match=r"links\.crank\.shap.*unknown key"):
        load_workflow(path, sets=["links.crank.shap.type=box"])


def test_joint_reactions_are_series_and_csv_columns(tmp_path):
    """Kinetostatic reactions were computed and written nowhere. Without inertia the
    ground's two pins carry the whole weight of the three bars (6 kg x 9.81 m/s^2) and
    no net horizontal force (the crank torque is a couple)."""
    import csv as csvmod

    import numpy as np

    text = FOURBAR.replace("    type: kinematic\n", "    type: kinetostatic\n    reactions: true\n")
    text = text.replace("    - {name: rocker, analysis: turn, series: [q:JD.theta]}",
                        "    - {name: rocker, analysis: turn, series: [reaction:JA:fy, "
                        "reaction:JD:fy, reaction:JB:force]}")
    res = run_workflow(_write(tmp_path, text), out_root=tmp_path / "out",
                       cache_dir=tmp_path / "links")
    assert res.manifest["status"] == "ok", res.manifest["analyses"]
    with open(res.out_dir / "turn_slow.csv") as fh:
        rows = list(csvmod.DictReader(fh))
    fy = np.array([float(r["reaction:JA.fy_N"]) + float(r["reaction:JD.fy_N"]) for r in rows])
    fx = np.array([float(r["reaction:JA.fx_N"]) + float(r["reaction:JD.fx_N"]) for r in rows])
    np.testing.assert_allclose(fy, 6.0 * 9.81, rtol=1e-9)
    np.testing.assert_allclose(fx, 0.0, atol=1e-9)
    assert (res.out_dir / "rocker.png").exists()
    with pytest.raises(ConfigError, match="reaction:<joint>"):  # before any analysis
        run_workflow(_write(tmp_path, text.replace("reaction:JB:force", "reaction:JZ:force")),
                     out_root=tmp_path / "out2", cache_dir=tmp_path / "links")


def test_task_board_tracks_queued_running_and_finished_tasks():
    from pipeline.core.progress import TaskBoard

    board = TaskBoard(["a", "b", "c"])
    board.running(1, 10.0)
    board.running(1, 12.0)  # started once
    board.finished(2, "lost", 3.5)
    assert board.state == ["queued", "running", "lost"] and board.began[1] == 10.0
    assert board.n_done == 1


@pytest.mark.gmsh
def test_a_budget_stopped_run_keeps_its_histories_and_draws_what_they_allow(tmp_path):
    """Issue 26, seen 4: a step budget that stops both cases of the double pendulum at its
    first output used to end "internal error (Data cannot be log-scaled)", exit 3, nothing
    written: the convergence chart had no finite bar. Now the run is partial, every output
    is written from the histories up to the stop, and the chart's comparison is noted."""
    root = Path(__file__).resolve().parents[2]
    res = run_workflow(root / "workflows" / "double_pendulum.yaml", quick=True,
                       sets=["analyses.swing.max_steps=3"], out_root=tmp_path / "out",
                       cache_dir=tmp_path / "links")
    man = json.loads((res.out_dir / "manifest.json").read_text())
    assert man["status"] == "partial"
    for f in ("rigid_vs_flexible.png", "rigid_vs_flexible.csv", "angles.png", "swing_rigid.csv",
              "swing_flexible.npz", "swing_still.png"):
        assert f in man["files"] and (res.out_dir / f).is_file(), f
    notes = "\n".join(man["skipped_outputs"])
    assert "convergence 'rigid_vs_flexible': compared over the common times only" in notes
    assert "stopped at t = 0 s" in notes
    cases = {c["case"]: c for c in man["analyses"]["swing"]}
    assert all("step budget of 3 steps exhausted" in c["message"] for c in cases.values())


def test_a_convergence_chart_without_a_finite_difference_says_so(tmp_path):
    from pipeline.post.study_plot import plot_convergence

    p = plot_convergence(tmp_path / "c.png", ["rigid", "flexible"],
                         {"q:J1.theta": [np.nan, 0.0], "q:J2.theta": [np.inf, 0.0]},
                         reference="flexible")
    assert p.stat().st_size > 1000


# --- strict numbers, every error at its own line (issue 26, seen 6) ---------------------------

@pytest.mark.parametrize("value, what", [("true", "True (a boolean)"),
                                         ("'0.008'", "'0.008' (str)")])
def test_a_recipe_parameter_must_be_a_number_at_its_own_line(tmp_path, capsys, value, what):
    """``geometry.params.b: true`` built a 1 m wide bar and ``'0.008'`` was read as a
    number; both are refused, at the parameter's line."""
    from pipeline.cli import main

    root = Path(__file__).resolve().parents[2]
    text = (root / "meshes" / "al_bar.yaml").read_text().replace(
        "  params: {L: 0.4, b: 0.008, h: 0.004}", f"  params:\n    L: 0.4\n    b: {value}\n"
                                                  f"    h: 0.004")
    p = tmp_path / "bar.yaml"
    p.write_text(text)
    assert main(["reduce", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    line = text.splitlines().index(f"    b: {value}") + 1
    assert err.startswith(f"error: {p}:{line}: geometry.params.b: "), err
    assert f"params.b: expected a number, got {what}" in err


@pytest.mark.parametrize("axis", ["[0, 0, 0]", "[0.0, 0.0, 0.0]"])
def test_a_zero_frame_axis_is_one_line_at_the_frame(tmp_path, capsys, axis):
    """It printed numpy's RuntimeWarnings and a four-line array of NaN without file:line."""
    import warnings

    from pipeline.cli import main

    text = FOURBAR.replace("D: {origin: [3.5, 0, 0]}", f"D: {{origin: [3.5, 0, 0], z: {axis}}}")
    p = _write(tmp_path, text)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning on the way
        assert main(["validate", str(p), "--build"]) == 2
    err = capsys.readouterr().err.strip()
    line = next(i for i, t in enumerate(text.splitlines(), 1) if "D: {origin" in t)
    assert err == (f"error: {p}:{line}: links.ground.frames.D: z_axis: expected a direction, "
                   "got the zero vector [0.0, 0.0, 0.0]")
    from pipeline.workflow.link_build import frame_axes

    np.testing.assert_allclose(frame_axes([1e-320, 0, 0])[:, 2], [1.0, 0.0, 0.0])


# --- bounded inputs (issue 26, seen 5) --------------------------------------------------------

@pytest.mark.parametrize("script, line, expect", [
    ("// many points\nFor i In {1:1e12}\n  Point(i) = {i, 0, 0};\nEndFor\n", 2,
     "a For loop of 1e+12 passes (at most 1e+06)"),
    ("For (1:10:0)\nEndFor\n", 1, "a For loop with a zero step never ends"),
    ("Macro Grow\n  Call Shrink;\nReturn\nMacro Shrink\n  Call Grow;\nReturn\nCall Grow;\n", 1,
     "macro 'Grow' calls itself"),
    ('w = GetValue("width?", 1);\n', 1, "the .geo command 'GetValue' is not allowed"),
])
def test_a_gmsh_script_that_would_not_end_is_refused_before_gmsh_runs(tmp_path, script, line,
                                                                      expect):
    p = tmp_path / "s.geo"
    p.write_text(script)
    with pytest.raises(MeshError, match=re.escape(f"{p}:{line}: {expect}")):
        check_geo_script(p)


def test_a_short_literal_loop_passes_the_scan(tmp_path):
    p = tmp_path / "s.geo"
    p.write_text("For i In {1:100:0.5}\n  x = i;\nEndFor\n// For i In {1:1e12} in a comment\n")
    check_geo_script(p)


@pytest.mark.parametrize("target", ["/dev/zero", "fifo", "folder"])
def test_a_driver_table_that_is_not_a_regular_file_is_one_line(tmp_path, target):
    """A table at /dev/zero was read for ever."""
    if target == "fifo":
        os.mkfifo(tmp_path / "t.csv")
        target = str(tmp_path / "t.csv")
    elif target == "folder":
        target = str(tmp_path)
    text = FOURBAR.replace("JA.theta: {type: ramp, t0: 0.0, rate: 6.283185307179586, v0: 1.0}",
                           f"JA.theta: {{type: table, file: {target}}}")
    p = _write(tmp_path, text)
    line = next(i for i, t in enumerate(text.splitlines(), 1) if "type: table" in t)
    with pytest.raises(ConfigError) as exc:
        from pipeline.workflow import build_machine

        build_machine(load_workflow(p), tmp_path / "links")
    assert str(exc.value) == (f"{p}:{line}: drivers.JA.theta.file: {target}: the table file is "
                              "not a regular file (a device, a pipe or a folder); give a file")


def test_cad_and_tables_beyond_their_size_and_recipe_lengths_beyond_range_are_refused(
        tmp_path, monkeypatch):
    """A 600 MB STEP file was imported for minutes; a point at 1e30 m built a 1e30 m plate
    in OCC before the mesh budget looked at it."""
    import pipeline.core.input_files as inp
    from pipeline.core.input_files import input_file

    big = tmp_path / "big.step"
    with open(big, "wb") as fh:
        fh.truncate(inp.MAX_CAD_BYTES + 1)  # sparse: no disk used
    with pytest.raises(ConfigError, match=r"the CAD file is 100.0 MB; at most 100 MB is read"):
        input_file(big, "CAD file", inp.MAX_CAD_BYTES)
    from pipeline.meshing.gmsh_build import check_extent

    with pytest.raises(ConfigError, match=r"params.points\[1\]\[0\]: 1e\+30 m is beyond"):
        check_extent({"points": [[0.0, 0.0], [1e30, 0.0]], "width": 0.1}, "link 'x'")
    check_extent({"points": [[0.0, 0.0], [24.0, 0.0]], "width": 0.1}, "link 'x'")


def test_a_position_beyond_1000_km_is_one_line(tmp_path):
    """The 2000-mutant fuzzer found it: a frame origin at 1e308 m overflowed the 4x4
    products (a RuntimeWarning, then a traceback). Positions are bounded at load."""
    text = FOURBAR.replace("D: {origin: [3.5, 0, 0]}", "D: {origin: [1.0e308, 0, 0]}")
    p = _write(tmp_path, text)
    line = next(i for i, t in enumerate(text.splitlines(), 1) if "1.0e308" in t)
    with pytest.raises(ConfigError) as exc:
        load_workflow(p)
    assert str(exc.value) == (f"{p}:{line}: links.ground.frames.D.origin[0]: Input should be "
                              "less than or equal to 1000000")
