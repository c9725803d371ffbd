"""Artifact reuse: hit, miss on changed inputs, corrupted file rebuilt."""

import numpy as np
import pytest
from link_samples import random_link as _random_link

from pipeline.invariants.cache import cached_reduced_link
from pipeline.invariants.store import save_reduced_link


def test_hit_miss_and_corrupt(tmp_path):
    path = tmp_path / "arm.npz"
    builds = []

    def build(tag):
        def _b():
            builds.append(tag)
            return _random_link(seed=len(builds))
        return _b

    link0 = _random_link()  # meta input_hash "abc"
    save_reduced_link(link0, path)
    link, status = cached_reduced_link(path, "abc", build("never"))
    assert status == "hit" and builds == []
    np.testing.assert_array_equal(link.C, link0.C)

    link, status = cached_reduced_link(path, "changed", build("stale"))
    assert status == "miss" and builds == ["stale"]

    raw = path.read_bytes()
    path.write_bytes(raw[:-100])
    link, status = cached_reduced_link(path, "abc", build("corrupt"))
    assert status == "corrupt" and builds[-1] == "corrupt"


@pytest.mark.gmsh
def test_spec_change_rebuilds_and_unchanged_reuses(tmp_path):
    from link_samples import write_bar

    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    out = tmp_path / "links"
    spec = write_bar(tmp_path, modes=3)
    a, s1 = reduce_spec(load_link_spec(spec), tmp_path, out)
    b, s2 = reduce_spec(load_link_spec(spec), tmp_path, out)
    assert (s1, s2) == ("miss", "hit")
    np.testing.assert_array_equal(a.Cpp, b.Cpp)
    spec = write_bar(tmp_path, modes=4)
    c, s3 = reduce_spec(load_link_spec(spec), tmp_path, out)
    assert s3 == "miss" and c.n_modes == 4
    (out / "bar.npz").write_bytes(b"not a zip at all")
    d, s4 = reduce_spec(load_link_spec(spec), tmp_path, out)
    assert s4 == "corrupt" and d.n_modes == 4
    assert sorted(p.name for p in out.iterdir()) == ["bar.npz"]
