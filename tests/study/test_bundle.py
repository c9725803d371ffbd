"""The study bundle: the files a study's workers need, by content, unpacked once per
machine with their relative layout, nothing outside it, old bundles pruned."""

from __future__ import annotations

import os
import time
from types import SimpleNamespace

import pytest

from pipeline.study import bundle as B


def test_a_bundle_keeps_the_layout_and_its_key_follows_the_contents(tmp_path, monkeypatch):
    monkeypatch.setattr(B.tempfile, "gettempdir", lambda: str(tmp_path / "worker"))
    (tmp_path / "p" / "workflows").mkdir(parents=True)
    (tmp_path / "p" / "meshes").mkdir()
    wf = tmp_path / "p" / "workflows" / "w.yaml"
    wf.write_text("spec: ../meshes/l.yaml\n")
    (tmp_path / "p" / "meshes" / "l.yaml").write_text("name: l\n")
    (tmp_path / "cache" / "l-abc").mkdir(parents=True)
    (tmp_path / "cache" / "l-abc" / "l.npz").write_bytes(b"\x00artifact")
    (tmp_path / "cache" / "other-def").mkdir()
    (tmp_path / "cache" / "other-def" / "o.npz").write_bytes(b"not needed")
    b = B.study_bundle(SimpleNamespace(path=wf), [tmp_path / "p" / "meshes" / "l.yaml"],
                       ["l-abc"], tmp_path / "cache")
    assert b.workflow == "project/workflows/w.yaml"
    assert sorted(b.files) == ["links/l-abc/l.npz", "project/meshes/l.yaml",
                               "project/workflows/w.yaml"]
    root = B.unpack(b)
    assert root == B.bundle_folder(b.key)
    assert (root / "project" / "meshes" / "l.yaml").read_text() == "name: l\n"
    assert (root / "links" / "l-abc" / "l.npz").read_bytes() == b"\x00artifact"
    assert B.unpack(b) == root  # once
    (tmp_path / "p" / "meshes" / "l.yaml").write_text("name: l2\n")
    b2 = B.study_bundle(SimpleNamespace(path=wf), [tmp_path / "p" / "meshes" / "l.yaml"],
                        ["l-abc"], tmp_path / "cache")
    assert b2.key != b.key


def test_a_path_that_leaves_the_bundle_is_refused_and_old_bundles_go(tmp_path, monkeypatch):
    monkeypatch.setattr(B.tempfile, "gettempdir", lambda: str(tmp_path))
    old = tmp_path / B.FOLDER / "old"
    old.mkdir(parents=True)
    (old / ".complete").write_text("old")
    past = time.time() - 2 * B.KEEP_SECONDS
    os.utime(old / ".complete", (past, past))
    with pytest.raises(ValueError, match="leaves the bundle"):
        B.unpack(B.Bundle("k" * 64, "project/w.yaml", {"../escape": b"x"}))
    assert not old.exists() and not (tmp_path / "escape").exists()
    assert not B.bundle_folder("k" * 64).exists()
