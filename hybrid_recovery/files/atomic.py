"""Atomic writes: a temporary file next to the target, synced, then renamed over it.

A crash at any point leaves the old file or the new one, never a part of either. An
existing output is replaced only when asked (:func:`refuse_existing`).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any


def refuse_existing(path: str | Path, force: bool, what: str = "") -> None:
    """Refuses to overwrite ``path`` unless ``force``.

    Args:
        path: The output about to be written.
        force: ``--force`` was given: overwriting is allowed.
        what: What ``path`` holds, for the message (default: nothing said).

    Raises:
        FileExistsError: ``<path> already exists; pass --force to overwrite it`` (with
            ``what``: ``<path> already holds <what>; pass --force to overwrite it``).
    """
    path = Path(path)
    if force or not (path.exists() or path.is_symlink()):
        return
    held = f"already holds {what}" if what else "already exists"
    raise FileExistsError(f"{path} {held}; pass --force to overwrite it")


def atomic_write(path: str | Path, mode: str, write: Callable[[Any], object]) -> None:
    """Calls ``write(handle)`` on a temporary file next to ``path`` opened with ``mode``,
    syncs it, then renames it to ``path``; on any error the temporary file is removed
    and ``path`` is untouched."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.chmod(fd, _file_mode(path))
        with os.fdopen(fd, mode) as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    _sync_directory(path.parent)


def atomic_write_text(text: str, path: str | Path) -> None:
    """Writes ``text`` to ``path`` atomically (:func:`atomic_write`)."""
    atomic_write(path, "w", lambda handle: handle.write(text))


def atomic_write_bytes(data: bytes, path: str | Path) -> None:
    """Writes ``data`` to ``path`` atomically (:func:`atomic_write`)."""
    atomic_write(path, "wb", lambda handle: handle.write(data))


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path next to ``path``, with its suffix, for a writer that takes a file
    name (``savefig``, a video writer, ``np.savez``); renamed to ``path`` when the block
    ends without an error, removed otherwise.

    Yields:
        The temporary path (nothing exists there yet).
    """
    path = Path(path)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        with tmp.open("rb") as handle:
            os.fsync(handle.fileno())
        os.chmod(tmp, _file_mode(path))
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _sync_directory(path.parent)


@contextlib.contextmanager
def staged_directory(out: str | Path, stale: Iterable[str] = ()) -> Iterator[Path]:
    """A staging directory next to ``out`` for files that are written together; when the
    block ends without an error they are moved into ``out``, otherwise removed.

    A new ``out`` is the staging directory renamed (one atomic step); into an existing
    one each file is renamed over its namesake, and the names in ``stale`` that the block
    did not write are removed (an earlier run's files that would no longer belong).

    Yields:
        The staging directory (empty).
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.", suffix=".staging"))
    try:
        os.chmod(staging, 0o777 & ~_umask())
        yield staging
        for written in (p for p in staging.iterdir() if p.is_file()):
            with written.open("rb") as handle:
                os.fsync(handle.fileno())
        if not out.exists():
            os.rename(staging, out)
        else:
            names = {p.name for p in staging.iterdir()}
            for name in sorted(names):
                os.replace(staging / name, out / name)
            for name in set(stale) - names:
                (out / name).unlink(missing_ok=True)
            staging.rmdir()
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    _sync_directory(out)
    _sync_directory(out.parent)


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _file_mode(path: Path) -> int:
    """The mode the written file gets: the replaced file's, else 0666 less the umask
    (``mkstemp`` creates 0600)."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        return 0o666 & ~_umask()


def _sync_directory(directory: Path) -> None:
    """fsync a directory so that a rename in it survives a power loss (best effort)."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
