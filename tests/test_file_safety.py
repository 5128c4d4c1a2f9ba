"""Output files: atomic writes leave the old file or the new one, an existing output is
refused without ``--force``, and one writer at a time holds a lock that names its pid."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from hybrid_recovery.files import (
    FileLockedError,
    atomic_path,
    atomic_write_text,
    exclusive_lock,
    lock_file,
    refuse_existing,
    sha256_file,
    staged_directory,
)

ROOT = Path(__file__).resolve().parents[1]
HOLD = ("import sys, time\n"
        "from hybrid_recovery.files import exclusive_lock\n"
        "with exclusive_lock(sys.argv[1]):\n"
        "    print('held', flush=True)\n"
        "    time.sleep(60)\n")


def _hold(path: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(path)], env=env,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline() == "held\n"
    return proc


def _leftovers(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name.startswith("."))


def test_an_existing_output_is_refused_naming_it_and_force(tmp_path):
    out = tmp_path / "out.mp4"
    refuse_existing(out, force=False)  # nothing there
    out.write_bytes(b"old")
    with pytest.raises(FileExistsError) as info:
        refuse_existing(out, force=False)
    assert str(info.value) == f"{out} already exists; pass --force to overwrite it"
    with pytest.raises(FileExistsError) as info:
        refuse_existing(tmp_path, force=False, what="an exported policy (policy.onnx)")
    assert str(info.value) == (f"{tmp_path} already holds an exported policy (policy.onnx); "
                               "pass --force to overwrite it")
    refuse_existing(out, force=True)


def test_a_failed_atomic_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "config.json"
    atomic_write_text("old", path)
    umask = os.umask(0o022)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask  # not mkstemp's private 0600

    class Torn(Exception):
        pass

    def torn(handle):
        handle.write("ne")
        raise Torn

    from hybrid_recovery.files import atomic_write

    with pytest.raises(Torn):
        atomic_write(path, "w", torn)
    assert path.read_text() == "old" and _leftovers(tmp_path) == []
    with pytest.raises(Torn), atomic_path(tmp_path / "figure.png") as tmp:
        assert tmp.suffix == ".png" and tmp.parent == tmp_path
        tmp.write_bytes(b"half")
        raise Torn
    assert sorted(p.name for p in tmp_path.iterdir()) == ["config.json"]
    with atomic_path(tmp_path / "figure.png") as tmp:
        tmp.write_bytes(b"whole")
    assert (tmp_path / "figure.png").read_bytes() == b"whole"
    assert sha256_file(tmp_path / "figure.png") == hashlib.sha256(b"whole").hexdigest()


def test_staged_files_move_in_together_or_not_at_all(tmp_path):
    out = tmp_path / "export"
    with staged_directory(out) as staging:
        (staging / "a").write_text("1")
        (staging / "b").write_text("1")
    assert sorted(p.name for p in out.iterdir()) == ["a", "b"]
    with pytest.raises(RuntimeError), staged_directory(out, stale=("a", "b")) as staging:
        (staging / "a").write_text("2")
        raise RuntimeError("failed half-way")
    assert (out / "a").read_text() == "1" and (out / "b").read_text() == "1"
    with staged_directory(out, stale=("a", "b")) as staging:
        (staging / "a").write_text("2")
    assert sorted(p.name for p in out.iterdir()) == ["a"] and (out / "a").read_text() == "2"
    assert _leftovers(tmp_path) == []
    with pytest.raises(RuntimeError), staged_directory(tmp_path / "new") as staging:
        raise RuntimeError("nothing written")
    assert not (tmp_path / "new").exists() and _leftovers(tmp_path) == []


def test_a_second_writer_is_refused_naming_the_holders_pid(tmp_path):
    target = tmp_path / "runs" / "r1"
    holder = _hold(target)
    try:
        assert lock_file(target).read_text() == f"{holder.pid}\n"
        with pytest.raises(FileLockedError) as info, exclusive_lock(target):
            pass
        assert str(info.value) == (f"{target} is in use by another process (pid "
                                   f"{holder.pid}); wait for it to end")
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    with exclusive_lock(target, "wait") as path:  # the kernel released the killed holder's
        with exclusive_lock(target):  # re-entrant in one process
            assert path.read_text() == f"{os.getpid()}\n"
    assert not path.exists()


def test_a_lock_removes_the_directory_it_made_when_left_empty(tmp_path):
    target = tmp_path / "a" / "b" / "results.jsonl"
    with exclusive_lock(target):
        assert (tmp_path / "a" / "b").is_dir()
    assert list(tmp_path.iterdir()) == []
    with exclusive_lock(target):
        target.write_text("{}\n")
    assert target.is_file() and _leftovers(target.parent) == []
