"""The reduced link in HDF5 (issue 28 item 3): exact round trip, the documented layout read
by plain h5py as another tool would, and refusals of foreign or newer files."""

from dataclasses import replace

import numpy as np
import pytest
from link_samples import random_link

from pipeline.core.errors import ArtifactError
from pipeline.invariants.hdf5 import FORMAT, read_hdf5, write_hdf5

h5py = pytest.importorskip("h5py")


def _full_link():
    link = random_link(m=3, n=20)
    rng = np.random.default_rng(5)
    return replace(link, geometric_stiffness=rng.standard_normal((6, 3, 3)),
                   force_geometric_stiffness=rng.standard_normal((3, 3, 3, 3)),
                   inertia_geometric_stiffness=rng.standard_normal((4, 3, 3, 3)),
                   stress_modes=rng.standard_normal((3, 20, 6)).astype(np.float32))


def test_round_trip_is_exact(tmp_path):
    link = _full_link()
    back = read_hdf5(write_hdf5(link, tmp_path / "arm.h5"))
    for name in ("body_pose", "C", "Cp", "Cpp", "modal_stiffness", "modal_mass",
                 "frequencies_hz", "nodes", "cells", "surface", "mode_shapes",
                 "geometric_stiffness", "force_geometric_stiffness",
                 "inertia_geometric_stiffness", "stress_modes"):
        a, b = getattr(back, name), getattr(link, name)
        assert a.dtype == b.dtype and a.shape == b.shape, name
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert (back.name, back.kind, back.mode_kinds) == (link.name, link.kind, link.mode_kinds)
    assert [(f.name, f.kind) for f in back.frames] == [(f.name, f.kind) for f in link.frames]
    for f, g in zip(back.frames, link.frames, strict=True):
        for k in ("pose", "phi", "psi"):
            np.testing.assert_array_equal(getattr(f, k), getattr(g, k))
    assert back.meta == link.meta
    # without the optional parts: none written, none read
    bare = read_hdf5(write_hdf5(random_link(), tmp_path / "bare.h5"))
    assert bare.geometric_stiffness.shape == (0, 3, 3) and bare.stress_modes.shape[0] == 0


def test_the_documented_layout_reads_without_the_pipeline(tmp_path, bar_link):
    """What docs/hdf5_format.md promises, read with h5py alone: the bar's mass is rho V, its
    modal matrices give its frequencies, the tip frame is where the spec put it."""
    from scipy.linalg import eigh

    _, link = bar_link
    path = write_hdf5(link, tmp_path / "bar.h5")
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == FORMAT and f.attrs["format_version"] == 1
        assert f["mass/C"][3, 3] == pytest.approx(2700 * 0.2 * 0.02 * 0.01, rel=1e-9)
        w2 = eigh(f["modes/stiffness"][()], f["modes/mass"][()], eigvals_only=True)
        np.testing.assert_allclose(np.sqrt(w2) / (2 * np.pi), f["modes/frequencies_hz"][()],
                                   rtol=1e-9)
        frames = {f["frames"][k].attrs["name"]: f["frames"][k] for k in f["frames"]}
        # body axes: z along the bar (the root interface's z_axis)
        np.testing.assert_allclose(frames["tip"]["pose"][:3, 3], [0, 0, 0.2], atol=1e-12)
        assert frames["mid"].attrs["kind"] == "marker"
        m, N = f["modes/shapes"].shape[:2]
        assert f["mesh/nodes"].shape == (N, 3) and f["mesh/cells"].attrs["cell_type"] == "tetra10"
        assert f["frames/1/phi"].shape == (m, 3)
        assert "units" in f["mass/Cpp"].attrs


def test_foreign_and_newer_files_are_refused(tmp_path):
    path = write_hdf5(random_link(), tmp_path / "arm.h5")
    with h5py.File(path, "a") as f:
        f.attrs["format_version"] = 2
    with pytest.raises(ArtifactError, match="newer than this tool reads"):
        read_hdf5(path)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = np.zeros(3)
    with pytest.raises(ArtifactError, match="not a flexmech.ReducedLink file"):
        read_hdf5(other)
    (tmp_path / "junk.h5").write_bytes(b"not hdf5")
    with pytest.raises(ArtifactError, match="unreadable"):
        read_hdf5(tmp_path / "junk.h5")
