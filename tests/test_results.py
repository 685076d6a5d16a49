"""Result objects: save/load round trip without pickling, atomic writes, kind dispatch."""

import json
import os

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.results import Result, load_result, make_meta


class _Toy(Result):
    kind = "test_toy"


def test_round_trip_preserves_arrays_and_meta(tmp_path):
    arrays = {"x": np.linspace(0, 1, 7), "k": np.arange(5, dtype=np.int64)}
    meta = make_meta(Params(f=58.0), seed=3, wall_s=0.5, note="hello")
    path = _Toy(arrays, meta).save(tmp_path / "toy")
    loaded = load_result(path)
    assert isinstance(loaded, _Toy)
    for key, value in arrays.items():
        np.testing.assert_array_equal(loaded[key], value)
        assert loaded[key].dtype == value.dtype
    assert loaded.meta["params"]["f"] == 58.0
    assert loaded.meta["seed"] == 3
    assert loaded.meta["note"] == "hello"
    assert not list(tmp_path.glob("*.tmp")), "temporary files left behind"


def test_object_arrays_are_refused_on_load(tmp_path):
    """Stored results load with allow_pickle=False, so no code runs on load."""
    np.savez(tmp_path / "evil.npz", x=np.array([{"a": 1}], dtype=object))
    (tmp_path / "evil.json").write_text(json.dumps({"kind": "test_toy", "meta": {}}))
    with pytest.raises(ValueError, match="pickle"):
        load_result(tmp_path / "evil")


def test_unknown_kind_is_refused(tmp_path):
    _Toy({"x": np.zeros(1)}, {}).save(tmp_path / "a")
    (tmp_path / "a.json").write_text(json.dumps({"kind": "nope", "meta": {}}))
    with pytest.raises(ValueError, match="unknown result kind 'nope'"):
        load_result(tmp_path / "a")


def test_load_checks_the_class(tmp_path):
    class _Other(Result):
        kind = "test_other"

    path = _Toy({"x": np.zeros(1)}, {}).save(tmp_path / "a")
    with pytest.raises(TypeError, match="not a _Other"):
        _Other.load(path)


def test_dots_in_the_name_are_not_taken_for_a_suffix(tmp_path):
    """Points of a 0.2 Hz scan are named f_50.000000000, f_50.200000000: they must not collide."""
    for value in (0.0, 0.2):
        _Toy({"x": np.array([value])}, {}).save(tmp_path / f"f_50.{round(value * 1e9):09d}")
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "f_50.000000000.json", "f_50.000000000.npz", "f_50.200000000.json", "f_50.200000000.npz",
    ]  # fmt: skip
    assert load_result(tmp_path / "f_50.200000000")["x"][0] == 0.2
    assert load_result(tmp_path / "f_50.200000000.json")["x"][0] == 0.2


@pytest.mark.parametrize("umask", [0o022, 0o027], ids=["022", "027"])
def test_saved_files_follow_the_umask(tmp_path, umask):
    """Files are created as 0666 & ~umask (0644 under the usual umask), like any other file."""
    old = os.umask(umask)
    try:
        _Toy({"x": np.zeros(3)}, {}).save(tmp_path / "a")
    finally:
        os.umask(old)
    for name in ("a.npz", "a.json"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o666 & ~umask, name


@pytest.mark.parametrize("how", ["truncated", "empty", "flipped_byte"])
def test_damaged_arrays_are_named_on_load(tmp_path, how):
    """The .json records the checksum of its .npz: any change to the .npz is found."""
    _Toy({"x": np.arange(100.0)}, {}).save(tmp_path / "a")
    npz = tmp_path / "a.npz"
    data = bytearray(npz.read_bytes())
    if how == "truncated":
        data = data[: len(data) // 2]
    elif how == "empty":
        data = bytearray()
    else:
        data[len(data) // 2] ^= 0xFF  # inside the array data: the zip still opens
    npz.write_bytes(bytes(data))
    with pytest.raises(ValueError, match=str(npz)):
        load_result(tmp_path / "a")


def test_garbage_json_is_named_on_load(tmp_path):
    _Toy({"x": np.zeros(1)}, {}).save(tmp_path / "a")
    (tmp_path / "a.json").write_text("{garbage")
    with pytest.raises(ValueError, match=str(tmp_path / "a.json")):
        load_result(tmp_path / "a")


def test_failed_write_leaves_no_file(tmp_path, monkeypatch):
    """A write cut short (here: disk full) leaves neither a half file nor a temporary file."""
    import errno

    import bbdyn.results

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(bbdyn.results.np, "savez", full)
    with pytest.raises(OSError, match="No space"):
        _Toy({"x": np.zeros(1)}, {}).save(tmp_path / "a")
    assert list(tmp_path.iterdir()) == []
