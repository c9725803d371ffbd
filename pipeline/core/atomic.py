"""Atomic file writes: a reader never sees a half-written result.

Everything is written to a temporary file in the destination folder and moved
into place with :func:`os.replace` (atomic on POSIX), so an interrupted run
leaves either the old file or the new one, never a truncated one. Folders are
swapped whole (:func:`replace_dir`), under a lock (:func:`folder_lock`), and measured by
what their files hold (:func:`folder_bytes`, for size budgets).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

import numpy as np


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` on success.

    On an exception the temporary file is removed and ``path`` is untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp makes 0600 files; results are for sharing, so use the usual mode
        umask = os.umask(0)
        os.umask(umask)
        if tmp_path.exists():
            os.chmod(tmp_path, 0o666 & ~umask)
        os.replace(tmp_path, path)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "w", **kwargs) -> Iterator[IO]:
    """``open`` that writes to a temporary file and renames it on success."""
    with atomic_path(path) as tmp, open(tmp, mode, **kwargs) as fh:
        yield fh


def save_npz_atomic(path: str | os.PathLike, **arrays: np.ndarray) -> Path:
    """Write ``arrays`` to a compressed ``.npz`` at ``path`` atomically."""
    path = Path(path)
    with atomic_open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return path


_RENAME_EXCHANGE = 2  # linux/fs.h


def _renameat2_exchange(a: Path, b: Path) -> bool:
    """Swap the paths a and b in one system call (Linux renameat2 RENAME_EXCHANGE); False
    where the platform or the file system cannot."""
    import ctypes
    import errno

    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):  # glibc < 2.28, musl
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                   ctypes.c_uint]
    at_fdcwd = -100
    if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def folder_bytes(folder: str | os.PathLike) -> int:
    """Bytes of the files in ``folder`` and its subfolders."""
    return sum(p.stat().st_size for p in Path(folder).rglob("*") if p.is_file())


def replace_dir(new: str | os.PathLike, final: str | os.PathLike,
                keep: str | os.PathLike | None = None) -> None:
    """Put the folder ``new`` in place of ``final`` in one atomic step, then delete the old
    contents, or move them to ``keep`` (a new folder on the same file system): a reader, or
    a kill at any instant, sees the old folder or the new one, never neither and never a
    mixture. Linux exchanges the two in one system call; elsewhere (or on a file system
    without it) the old folder is renamed away first, leaving a short window without
    ``final``."""
    new, final = Path(new), Path(final)

    def dispose(old: Path) -> None:
        if keep is not None:
            try:
                Path(keep).parent.mkdir(parents=True, exist_ok=True)
                old.rename(keep)
                return
            except OSError:
                pass  # kept nowhere: deleted as without ``keep``
        shutil.rmtree(old, ignore_errors=True)

    for _ in range(100):  # another process may create or replace final meanwhile
        if final.exists():
            if _renameat2_exchange(new, final):
                dispose(new)  # now the old contents
                return
            old = final.with_name(f".{final.name}.old-{os.getpid()}")
            try:
                final.rename(old)
            except FileNotFoundError:
                continue
            try:
                new.rename(final)
            except OSError:
                old.rename(final)
                raise
            dispose(old)
            return
        try:
            new.rename(final)
            return
        except OSError as exc:  # final appeared meanwhile (ENOTEMPTY / EEXIST): exchange
            if not final.exists():
                raise exc from None
    raise OSError(f"{final}: could not replace it (other processes keep changing it)")


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike, name: str) -> Iterator[None]:
    """Hold an exclusive lock on ``folder/.<name>.lock`` (a POSIX advisory lock, released
    when the process ends however it ends; the file is removed on release); a second
    holder gets a BlockingIOError at once."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    try:
        import fcntl
    except ImportError:  # Windows: no advisory locks; runs are not serialised there
        yield
        return
    path = folder / f".{name}.lock"
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BaseException:
            os.close(fd)
            raise
        try:  # the holder before us may have removed the file after we opened it
            if os.stat(path).st_ino == os.fstat(fd).st_ino:
                break
        except FileNotFoundError:
            pass
        os.close(fd)
    try:
        yield
    finally:
        path.unlink(missing_ok=True)  # while still holding it: no one locks a stale file
        os.close(fd)
