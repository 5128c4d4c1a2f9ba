"""Output files: written whole or not at all, never overwritten unasked, one writer at a
time, identified by content hash."""

from hybrid_recovery.files.atomic import (
    atomic_path,
    atomic_write,
    atomic_write_bytes,
    atomic_write_text,
    refuse_existing,
    staged_directory,
)
from hybrid_recovery.files.digest import sha256_file
from hybrid_recovery.files.lock import FileLockedError, exclusive_lock, lock_file

__all__ = ["FileLockedError", "atomic_path", "atomic_write", "atomic_write_bytes",
           "atomic_write_text", "exclusive_lock", "lock_file", "refuse_existing",
           "sha256_file", "staged_directory"]
