"""Scans that never lose or trust bad data (issue 10): damaged files, a second scan in the
same folder, a killed scan's workers, file modes, a full or read-only disk, an unreachable
scheduler.

The compute is ``synthetic`` of test_scan (a seeded random draw, with a hang switch);
the facts checked are the scan's: damage is detected and repaired to the numbers of an
undamaged scan, a refused scan writes nothing, a killed scan leaves no process behind.
"""

import errno
import functools
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from extras import require

import bbdyn.results
from bbdyn.scans.runner import load_scan, run_scan

sys.path.insert(0, str(Path(__file__).parent))
from test_scan import VALUES, _group_alive, synthetic  # noqa: E402

THREE = VALUES[:3]  # 50, 58, 60.2 Hz: the points that finish when the hang switch is on


def _scan(out, **kw):
    return run_scan(THREE, synthetic, out_dir=out, seed=3, workers=1, progress=False, **kw)


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """An undamaged scan: the numbers every repaired scan must reproduce."""
    return _scan(tmp_path_factory.mktemp("clean"))


def _same(a, b):
    assert list(a.arrays) == list(b.arrays)
    for k in a.arrays:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


# ---- damaged points: found on load, recomputed on resume ----------------------------------
def _truncate(path: Path, size: int) -> None:
    data = path.read_bytes()
    path.write_bytes(data[:size] if size >= 0 else data[: len(data) // 2])


def _swap(a: Path, b: Path) -> None:
    tmp = a.with_name("swap")
    a.rename(tmp)
    b.rename(a)
    tmp.rename(b)


def _damage(points: Path, how: str) -> list[Path]:
    """Damage the stored points as ``how`` says; returns the files that are now wrong."""
    p50, p58 = points / "f_50.000000000", points / "f_58.000000000"
    if how == "truncated_npz":
        _truncate(p50.with_suffix(".000000000.npz"), -1)
        return [p50.with_suffix(".000000000.npz")]
    if how == "empty_npz":
        _truncate(p50.with_suffix(".000000000.npz"), 0)
        return [p50.with_suffix(".000000000.npz")]
    if how == "garbage_json":
        p50.with_suffix(".000000000.json").write_text("{garbage")
        return [p50.with_suffix(".000000000.json")]
    if how == "swapped_points":  # both files of two points exchanged: each file is sound
        for suffix in (".npz", ".json"):
            _swap(Path(str(p50) + suffix), Path(str(p58) + suffix))
        return [Path(str(p50) + ".json"), Path(str(p58) + ".json")]
    if how == "npz_of_another_point":  # a sound .npz copied over another point's
        shutil.copy(str(p58) + ".npz", str(p50) + ".npz")
        return [Path(str(p50) + ".npz")]
    raise AssertionError(how)


DAMAGES = ["truncated_npz", "empty_npz", "garbage_json", "swapped_points", "npz_of_another_point"]


@pytest.mark.parametrize("how", DAMAGES)
def test_damaged_point_is_named_on_load(tmp_path, clean, how):
    _scan(tmp_path)
    bad = _damage(tmp_path / "points", how)
    with pytest.raises(ValueError, match="resume") as info:
        load_scan(tmp_path)
    assert any(str(p) in str(info.value) for p in bad), str(info.value)


@pytest.mark.parametrize("how", DAMAGES)
def test_damaged_point_is_recomputed_on_resume_with_a_warning(tmp_path, clean, how):
    _scan(tmp_path)
    bad = _damage(tmp_path / "points", how)
    with pytest.warns(UserWarning, match="again") as record:
        again = _scan(tmp_path)
    warned = " ".join(str(w.message) for w in record)
    assert all(str(p) in warned for p in bad), warned
    _same(again, clean)
    _same(load_scan(tmp_path), clean)


BAD_VALUES = (
    '{"kind": "scan_manifest", "name": "f", "values": ["x"], "keys": [1], "seed": 3, "compute": {}}'
)


@pytest.mark.parametrize(
    "content", ["", "{garbage", "[1, 2]", BAD_VALUES], ids=["empty", "garbage", "list", "values"]
)
def test_damaged_manifest_is_named_with_the_remedy(tmp_path, content):
    _scan(tmp_path)
    manifest = tmp_path / "manifest.json"
    manifest.write_text(content)
    for call in (lambda: load_scan(tmp_path), lambda: _scan(tmp_path)):
        with pytest.raises(ValueError, match="damaged") as info:
            call()
        assert str(manifest) in str(info.value) and "delete" in str(info.value)
    # the remedy it gives: delete the manifest, run the same scan again; points are kept
    mtimes = {p: p.stat().st_mtime_ns for p in (tmp_path / "points").glob("*.npz")}
    manifest.unlink()
    _scan(tmp_path)
    assert all(p.stat().st_mtime_ns == t for p, t in mtimes.items())


def test_point_of_another_scan_is_not_trusted(tmp_path, clean):
    """A point whose metadata names another seed (copied from another scan) is recomputed."""
    other = tmp_path / "other"
    run_scan(THREE, synthetic, out_dir=other, seed=4, workers=1, progress=False)
    _scan(tmp_path / "mine")
    for suffix in (".npz", ".json"):
        name = "f_58.000000000" + suffix
        shutil.copy(other / "points" / name, tmp_path / "mine" / "points" / name)
    with pytest.raises(ValueError, match="seed"):
        load_scan(tmp_path / "mine")
    with pytest.warns(UserWarning, match="f_58.000000000"):
        _same(_scan(tmp_path / "mine"), clean)


# ---- file modes -----------------------------------------------------------------------------
@pytest.mark.parametrize("umask", [0o022, 0o077], ids=["022", "077"])
def test_scan_files_follow_the_umask(tmp_path, umask):
    old = os.umask(umask)
    try:
        _scan(tmp_path)
    finally:
        os.umask(old)
    files = [tmp_path / "manifest.json", *(tmp_path / "points").iterdir()]
    assert len(files) == 1 + 2 * len(THREE)
    for path in files:
        assert path.stat().st_mode & 0o777 == 0o666 & ~umask, path


# ---- a second scan in the same folder -------------------------------------------------------
def _hanging_scan(out: Path, hang: Path, workers: int = 1) -> subprocess.Popen:
    """``run_scan`` of VALUES in a new process session; points above 60 Hz hang."""
    code = (
        "import sys, functools; sys.path.insert(0, sys.argv[1]);"
        "from test_scan import synthetic, VALUES; from bbdyn.scans.runner import run_scan;"
        "run_scan(VALUES, functools.partial(synthetic, hang_file=sys.argv[3]),"
        f" out_dir=sys.argv[2], seed=3, workers={workers}, progress=False)"
    )
    argv = [sys.executable, "-c", code, str(Path(__file__).parent), str(out), str(hang)]
    return subprocess.Popen(argv, start_new_session=True, stderr=subprocess.DEVNULL)


def _wait_for_points(out: Path, proc: subprocess.Popen, count: int) -> None:
    deadline = time.monotonic() + 30
    while len(list(out.glob("points/*.json"))) < count:
        assert time.monotonic() < deadline, f"the scan did not store {count} points in 30 s"
        assert proc.poll() is None, "the scan ended early"
        time.sleep(0.05)


def _stop_group(proc: subprocess.Popen) -> None:
    if _group_alive(proc.pid):
        os.killpg(proc.pid, signal.SIGKILL)  # only the processes this test started
    proc.wait()


def test_second_scan_in_a_busy_folder_is_refused(tmp_path):
    out, hang = tmp_path / "scan", tmp_path / "hang"
    hang.touch()
    proc = _hanging_scan(out, hang)
    try:
        _wait_for_points(out, proc, 2)
        compute = functools.partial(synthetic, hang_file=str(hang))
        t0 = time.monotonic()
        with pytest.raises(OSError, match="in use") as info:
            run_scan(VALUES, compute, out_dir=out, seed=3, workers=1, progress=False)
        assert time.monotonic() - t0 < 5
        assert str(out) in str(info.value) and f"PID {proc.pid}" in str(info.value)
    finally:
        _stop_group(proc)
    # the lock dies with its holder: the folder can be resumed now
    hang.unlink()
    compute = functools.partial(synthetic, hang_file=str(hang))
    res = run_scan(VALUES, compute, out_dir=out, seed=3, workers=1, progress=False)
    assert res.values.tolist() == VALUES


# ---- a killed scan leaves no process behind -------------------------------------------------
def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    with_proc = stat.exists()
    return not (with_proc and stat.read_text().rsplit(")", 1)[1].split()[0] == "Z")


def test_workers_exit_when_the_scan_is_killed(tmp_path):
    out, hang = tmp_path / "scan", tmp_path / "hang"
    hang.touch()
    proc = _hanging_scan(out, hang, workers=2)
    try:
        _wait_for_points(out, proc, 2)
        time.sleep(0.5)  # both workers now hang in a point above 60 Hz
        group = [p for p in _pids_of_group(proc.pid) if p != proc.pid]
        assert len(group) >= 2, group  # the workers (and the forkserver, resource tracker)
        os.kill(proc.pid, signal.SIGKILL)  # the scan only, as the OOM killer would
        proc.wait()
        deadline = time.monotonic() + 5
        while any(_alive(p) for p in group) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not [p for p in group if _alive(p)], "processes outlived the killed scan"
    finally:
        _stop_group(proc)


def _pids_of_group(pgid: int) -> list[int]:
    """Processes of the process group ``pgid`` (Linux /proc)."""
    if not Path("/proc/self/stat").exists():
        pytest.skip("needs /proc to list the scan's processes")
    pids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid:
            pids.append(int(stat.parent.name))
    return pids


# ---- full or read-only disk -----------------------------------------------------------------
@pytest.mark.parametrize(
    "code, words",
    [(errno.ENOSPC, "free disk space"), (errno.EACCES, "writable"), (errno.EROFS, "writable")],
    ids=["ENOSPC", "EACCES", "EROFS"],
)
def test_write_failure_stops_with_the_folder_and_resume_finishes(
    tmp_path, monkeypatch, clean, code, words
):
    real = np.savez
    calls = []

    def savez_then_fail(*args, **kwargs):
        calls.append(1)
        if len(calls) > 1:
            raise OSError(code, os.strerror(code))
        return real(*args, **kwargs)

    monkeypatch.setattr(bbdyn.results.np, "savez", savez_then_fail)
    with pytest.raises(OSError, match=words) as info:
        _scan(tmp_path)
    message = str(info.value)
    assert str(tmp_path) in message and "resume" in message, message
    assert not list((tmp_path / "points").glob("*.tmp")), "a half-written file was left"
    monkeypatch.setattr(bbdyn.results.np, "savez", real)
    assert len(load_scan(tmp_path, partial=True).values) == 1
    _same(_scan(tmp_path), clean)


def test_read_only_folder_refuses_before_computing(tmp_path, monkeypatch):
    """The first write of a scan is its manifest: on a read-only file system it fails there."""

    def read_only(*args, **kwargs):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS))

    monkeypatch.setattr(bbdyn.results, "_write_atomic", read_only)
    with pytest.raises(OSError, match="writable") as info:
        _scan(tmp_path)
    assert str(tmp_path) in str(info.value)
    assert not list(tmp_path.rglob("*.json")) and not list(tmp_path.rglob("*.tmp"))


def test_full_disk_in_the_command_is_a_short_message(tmp_path):
    """`bbdyn scan` on a disk that fills after the first point: exit 1, one clear line,
    no traceback and no leaked-semaphore warning; --resume then finishes the scan."""
    out = tmp_path / "scan"
    code = (
        "import errno, sys, numpy as np, bbdyn.results as r; real = np.savez; calls = [];\n"
        "def savez(*a, **k):\n"
        "    calls.append(1)\n"
        "    if len(calls) > 1: raise OSError(errno.ENOSPC, 'No space left on device')\n"
        "    return real(*a, **k)\n"
        "r.np.savez = savez\n"
        "from bbdyn.commands.cli import main; sys.exit(main(sys.argv[1:]))\n"
    )
    args = ["scan", "--f-start", "60", "--f-stop", "61", "--f-step", "0.5", "--n", "4",
            "--t", "1", "--workers", "1", "--out", str(out)]  # fmt: skip
    run = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                         timeout=120)  # fmt: skip
    assert run.returncode == 1, run.stderr
    assert "Traceback" not in run.stderr and "leaked" not in run.stderr, run.stderr
    assert str(out) in run.stderr and "free disk space" in run.stderr, run.stderr
    assert len(list(out.glob("points/*.json"))) == 1
    resumed = subprocess.run([sys.executable, "-m", "bbdyn.commands.cli", *args, "--resume"],
                             capture_output=True, text=True, timeout=120)  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr
    assert load_scan(out).values.tolist() == [60.0, 60.5, 61.0]


def test_interrupted_command_says_what_is_saved_and_how_to_finish(tmp_path):
    """Ctrl-C after the first of three points of `bbdyn scan`: one line saying that 1 of 3
    points is saved in the folder and the exact command that finishes the scan (run here:
    it computes the two others)."""
    import shlex

    out = tmp_path / "my scan"
    code = (
        "import sys, numpy as np, bbdyn.results as r; real = np.savez; calls = [];\n"
        "def savez(*a, **k):\n"
        "    calls.append(1)\n"
        "    if len(calls) > 1: raise KeyboardInterrupt\n"
        "    return real(*a, **k)\n"
        "r.np.savez = savez\n"
        "from bbdyn.commands.cli import main; sys.exit(main(sys.argv[1:]))\n"
    )
    args = ["scan", "--f-start", "60", "--f-stop", "61", "--f-step", "0.5", "--n", "4",
            "--t", "1", "--R", "20", "--workers", "1", "--out", str(out)]  # fmt: skip
    run = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                         timeout=120)  # fmt: skip
    assert run.returncode == 130, run.stderr
    (said,) = [line for line in run.stderr.splitlines() if line.startswith("interrupted")]
    assert f"1 of 3 points are saved in {out}" in said, said
    command = shlex.split(said.split("finish the scan with: ")[1])
    assert command[:2] == ["bbdyn", "scan"] and "--resume" in command
    resumed = subprocess.run([sys.executable, "-m", "bbdyn.commands.cli", *command[1:]],
                             capture_output=True, text=True, timeout=120)  # fmt: skip
    assert resumed.returncode == 0, resumed.stderr
    scan = load_scan(out)
    assert scan.values.tolist() == [60.0, 60.5, 61.0] and scan.meta["compute"]["kwargs"]["R"] == 20


# ---- unreachable scheduler ------------------------------------------------------------------
def test_unreachable_scheduler_fails_fast_and_writes_nothing(tmp_path):
    require("distributed", "dask")
    address = "tcp://127.0.0.1:1"
    t0 = time.monotonic()
    with pytest.raises(OSError, match="scheduler") as info:
        run_scan(THREE, synthetic, out_dir=tmp_path / "s", seed=3, scheduler=address)
    assert time.monotonic() - t0 < 15
    assert address in str(info.value) and "--scheduler" in str(info.value)
    assert not (tmp_path / "s").exists()
