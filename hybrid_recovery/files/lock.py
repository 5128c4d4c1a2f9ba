"""One writer at a time: an exclusive, non-blocking ``flock`` on a lock file beside what
is written, holding the writer's pid.

The lock file of ``results/eval/results.jsonl`` is ``results/eval/.results.jsonl.lock``
(of a directory ``runs/r1``: ``runs/.r1.lock``). The kernel releases the lock when its
holder exits, however it ends, so a lock never outlives its process; the holder removes
the file when it lets go. Within one process the lock is re-entrant.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from collections.abc import Iterator
from pathlib import Path

_HELD: dict[Path, int] = {}
"""Lock files this process holds → how many nested holds."""


class FileLockedError(RuntimeError):
    """Another process holds the lock; the message names the file and that process's pid."""


def lock_file(target: str | Path) -> Path:
    """The lock file of ``target`` (a file or a directory): ``.<name>.lock`` beside it."""
    target = Path(target).absolute()
    return target.with_name(f".{target.name}.lock")


@contextlib.contextmanager
def exclusive_lock(target: str | Path, hint: str = "wait for it to end") -> Iterator[Path]:
    """Holds the exclusive lock of ``target`` for the block; refuses at once if another
    process holds it.

    Args:
        target: What the block writes (a results file, a run directory); it need not
            exist. Its parent directory is created, and removed again at the end when
            the block left it empty.
        hint: What to do instead, the end of the refusal's message.

    Yields:
        The lock file (its content: the holder's pid).

    Raises:
        FileLockedError: ``<target> is in use by another process (pid <pid>); <hint>``.
    """
    path = lock_file(target)
    if path in _HELD:
        _HELD[path] += 1
        try:
            yield path
        finally:
            _HELD[path] -= 1
        return
    created = [p for p in (path.parent, *path.parent.parents) if not p.exists()]
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd = _acquire(path, Path(target), hint)
    except BaseException:
        _remove_empty(created)
        raise
    _HELD[path] = 1
    try:
        yield path
    finally:
        del _HELD[path]
        path.unlink(missing_ok=True)  # before the unlock: a waiting opener retries
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)
        _remove_empty(created)


def _remove_empty(directories: list[Path]) -> None:
    """Removes the directories the lock created (deepest first) that are still empty."""
    for directory in directories:
        try:
            directory.rmdir()
        except OSError:
            return


def _acquire(path: Path, target: Path, hint: str) -> int:
    """Opens and locks ``path``, writes the pid; retries when the file it locked was
    removed by the holder letting go in between (then it is not the lock file any more)."""
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except FileNotFoundError:  # a holder letting go removed the directory it made
            path.parent.mkdir(parents=True, exist_ok=True)
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
            os.close(fd)
            pid = f"pid {holder}" if holder.isdigit() else "pid unknown"
            raise FileLockedError(
                f"{target} is in use by another process ({pid}); {hint}") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            return fd
        fcntl.flock(fd, fcntl.LOCK_UN)
        os.close(fd)
