"""Artifact round trip, integrity checks and body-frame transforms."""

import numpy as np
import pytest
from link_samples import random_link as _random_link

from pipeline.core.errors import ArtifactError
from pipeline.invariants.body_frame import congruent, inverse_pose, points_to_body, pose
from pipeline.invariants.store import load_reduced_link, save_reduced_link


def test_round_trip_is_exact(tmp_path):
    link = _random_link()
    path = save_reduced_link(link, tmp_path / "arm.npz")
    back = load_reduced_link(path)
    for name in ("C", "Cp", "Cpp", "modal_stiffness", "frequencies_hz", "nodes", "cells",
                 "surface", "mode_shapes", "body_pose"):
        np.testing.assert_array_equal(getattr(back, name), getattr(link, name))
    assert [f.name for f in back.frames] == ["f0", "f1", "f2"]
    assert back.frames[2].kind == "marker"
    np.testing.assert_array_equal(back.frame("f1").psi, link.frame("f1").psi)
    assert back.meta["settings"] == {"n_modes": 3}
    assert back.mode_kinds == link.mode_kinds
    assert back.geometric_stiffness.shape == (0, 3, 3)  # not computed: none stored


def test_geometric_stiffness_round_trips(tmp_path):
    from dataclasses import replace

    link = _random_link()
    KG = np.random.default_rng(3).standard_normal((6, 3, 3))
    back = load_reduced_link(save_reduced_link(replace(link, geometric_stiffness=KG),
                                               tmp_path / "arm.npz"))
    np.testing.assert_array_equal(back.geometric_stiffness, KG)


def test_truncated_and_corrupted_files_are_rejected(tmp_path):
    path = save_reduced_link(_random_link(), tmp_path / "arm.npz")
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(ArtifactError, match="unreadable"):
        load_reduced_link(path)
    with pytest.raises(ArtifactError, match="not found"):
        load_reduced_link(tmp_path / "missing.npz")


def test_tampered_array_fails_digest(tmp_path):
    link = _random_link()
    path = save_reduced_link(link, tmp_path / "arm.npz")
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["C"] = arrays["C"] + 1e-12
    np.savez_compressed(path, **arrays)
    with pytest.raises(ArtifactError, match="digest"):
        load_reduced_link(path)


@pytest.mark.parametrize("edit", ["frame name", "frame kind", "mode kind", "name", "meta"])
def test_an_edited_header_fails_digest(tmp_path, edit):
    """The header's frame names and kinds are what the loader uses: an edit was used
    silently before (the digest covered only the arrays)."""
    import json

    path = save_reduced_link(_random_link(), tmp_path / "arm.npz")
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(str(arrays["header"]))
    if edit == "frame name":
        header["frames"][1][0] = "renamed"
    elif edit == "frame kind":
        header["frames"][2][1] = "interface"
    elif edit == "mode kind":
        header["mode_kinds"][0] = "constraint"
    elif edit == "name":
        header["name"] = "other"
    else:
        header["meta"]["settings"] = {"n_modes": 9}
    arrays["header"] = np.array(json.dumps(header))
    np.savez_compressed(path, **arrays)
    with pytest.raises(ArtifactError, match="digest"):
        load_reduced_link(path)


def test_body_frame_congruence_matches_direct_integration():
    """Moments of a point cloud transformed congruently equal moments of moved points."""
    rng = np.random.default_rng(1)
    x = rng.normal(size=(50, 3))
    m = rng.uniform(0.1, 1.0, 50)
    phi = rng.normal(size=(50, 3))
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1.0]])
    H = pose(np.array([0.3, -0.2, 0.5]), R)
    rbar = np.c_[x, np.ones(50)]
    pbar = np.c_[phi, np.zeros(50)]
    C = np.einsum("g,gi,gj->ij", m, rbar, rbar)
    Cp = np.einsum("g,gi,gj->ij", m, rbar, pbar)
    xb = points_to_body(H, x)
    rb = np.c_[xb, np.ones(50)]
    pb = np.c_[phi @ R, np.zeros(50)]
    Hi = inverse_pose(H)
    np.testing.assert_allclose(congruent(Hi, C), np.einsum("g,gi,gj->ij", m, rb, rb), atol=1e-12)
    np.testing.assert_allclose(congruent(Hi, Cp), np.einsum("g,gi,gj->ij", m, rb, pb), atol=1e-12)
