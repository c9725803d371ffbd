"""One link cache (issue 28 item 4): what ``pipeline reduce`` made, ``validate --build``,
``run`` and ``study`` reuse, whatever their --out; ``pipeline cache`` lists and clears it."""

from __future__ import annotations

import os
import time

import pytest
from link_samples import beam_spec

from pipeline.cli import main

WORKFLOW = """name: swing
gravity: [0, -9.81, 0]
links:
  ground: {type: ground, frames: {O: {origin: [0, 0, 0]}}}
  rod: {type: flexible, spec: rod.yaml, modes: 2}
joints:
  - {name: J, type: revolute, parent: ground.O, child: rod.root}
analyses:
  - {name: fall, type: dynamic, t_end: 0.05, outputs: 6}
outputs: {exports: {csv: true}}
"""


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "rod.yaml").write_text(beam_spec(
        "rod", 0.5, A=1e-4, Iy=1e-9, Iz=1e-9, J=2e-9, element_size=0.05, modes="{count: 3}"))
    (tmp_path / "swing.yaml").write_text(WORKFLOW)
    return tmp_path


def test_what_reduce_made_run_and_validate_reuse_whatever_their_out(folder, monkeypatch,
                                                                     capsys):
    assert main(["reduce", str(folder / "rod.yaml"), "--json"]) == 0
    capsys.readouterr()

    def no_reduction(*a, **k):
        raise AssertionError("the link was reduced again")

    monkeypatch.setattr("pipeline.invariants.reduce.reduce_link", no_reduction)
    for out in ("out1", "out2"):
        assert main(["run", str(folder / "swing.yaml"), "--out", str(folder / out),
                     "--workers", "1"]) == 0
    assert main(["validate", str(folder / "swing.yaml"), "--build"]) == 0
    assert "built in" in capsys.readouterr().out


def test_cache_lists_and_clears(folder, capsys):
    spec = folder / "rod.yaml"
    assert main(["reduce", str(spec)]) == 0
    spec.write_text(spec.read_text().replace("{count: 3}", "{count: 2}"))
    assert main(["reduce", str(spec)]) == 0  # another input: a second entry
    capsys.readouterr()
    cache = os.environ["FLEXMECH_LINKS"]
    (folder / "link-cache" / "not-an-entry").mkdir()  # left alone by the cache command
    assert main(["cache"]) == 0
    listing = capsys.readouterr().out
    assert listing.startswith(f"{cache}: 2 reduced links")
    assert listing.count(str(spec.resolve())) == 2
    old = next(p for p in (folder / "link-cache").iterdir() if p.name.startswith("rod-"))
    past = time.time() - 10 * 86400
    os.utime(old / "rod.npz", (past, past))
    assert main(["cache", "clear", "--older-than", "5"]) == 0
    assert "removed 1 reduced links" in capsys.readouterr().out
    assert not old.exists()
    assert main(["cache", "clear", "--name", "rod"]) == 0
    assert "removed 1 reduced links" in capsys.readouterr().out
    assert [p.name for p in (folder / "link-cache").iterdir()] == ["not-an-entry"]
    assert main(["cache", "--older-than", "-1"]) == 2


def test_a_reduced_link_exported_to_hdf5_runs_as_its_spec(folder):
    """`spec: rod.h5`, the reduced link `pipeline reduce --hdf5` wrote (or another tool in
    the documented format), is read and used as it is: the same machine as the spec's."""
    pytest.importorskip("h5py")
    from pipeline.workflow import run_workflow

    ref = run_workflow(folder / "swing.yaml", out_root=folder / "a", outputs=False)
    assert main(["reduce", str(folder / "rod.yaml"), "--hdf5", str(folder / "rod.h5")]) == 0
    (folder / "swing.yaml").write_text(WORKFLOW.replace("spec: rod.yaml", "spec: rod.h5"))
    res = run_workflow(folder / "swing.yaml", out_root=folder / "b", outputs=False)
    assert res.manifest["links"]["rod"]["cache"] == "file"
    a, b = ref.result("fall"), res.result("fall")
    assert b.verdict == "ok" and a.q.shape == b.q.shape and b.q.shape[1] == 3
    assert abs(a.q - b.q).max() < 1e-12


@pytest.mark.parametrize("change, where, expect", [
    ("spec: rod.h5, spec_overrides: {modes.count: 2}", "links.rod.spec_overrides",
     "a reduced link read from a file is used as it is"),
    ("spec: nope.h5", "links.rod.spec", "reduced link file .* not found"),
    ("spec: junk.h5", "links.rod.spec", r".*junk\.h5: unreadable HDF5 file"),
    ("spec: rod.h5, geometric_stiffening: true", "links.rod.geometric_stiffening",
     "rod.h5 holds no geometric stiffness"),
])
def test_a_bad_reduced_link_file_is_named_at_its_line(folder, change, where, expect):
    pytest.importorskip("h5py")
    from pipeline.core.errors import ConfigError
    from pipeline.workflow import run_workflow

    assert main(["reduce", str(folder / "rod.yaml"), "--hdf5", str(folder / "rod.h5")]) == 0
    (folder / "junk.h5").write_text("not HDF5")
    (folder / "swing.yaml").write_text(WORKFLOW.replace("spec: rod.yaml", change))
    with pytest.raises(ConfigError, match=rf"swing\.yaml:5: {where}: {expect}"):
        run_workflow(folder / "swing.yaml", out_root=folder / "out", outputs=False)
