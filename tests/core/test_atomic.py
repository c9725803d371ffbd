import numpy as np
import pytest

from pipeline.core.atomic import atomic_open, save_npz_atomic
from pipeline.core.hashing import content_hash


def test_atomic_write_leaves_old_file_on_failure(tmp_path):
    target = tmp_path / "result.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_open(target) as fh:
        fh.write("half")
        raise RuntimeError("boom")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["result.txt"]


def test_npz_round_trip(tmp_path):
    a = np.arange(12.0).reshape(3, 4)
    path = save_npz_atomic(tmp_path / "sub" / "a.npz", a=a)
    with np.load(path) as data:
        np.testing.assert_array_equal(data["a"], a)


def test_content_hash_changes_with_payload_and_files(tmp_path):
    f = tmp_path / "g.geo"
    f.write_text("Point(1) = {0,0,0};")
    h1 = content_hash({"E": 70e9}, (f,))
    assert h1 == content_hash({"E": 70e9}, (f,))
    assert h1 != content_hash({"E": 71e9}, (f,))
    f.write_text("Point(1) = {0,0,1};")
    assert h1 != content_hash({"E": 70e9}, (f,))
