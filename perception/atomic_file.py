"""Whole files written atomically: the product's one writer of complete files.

A file is written to a temporary name in its own folder, flushed to the disk
(``fsync``), then renamed over the final name (``os.replace``), so a crash or Ctrl-C
mid-write leaves either the previous complete file or the new complete file, never half
of one. The temporary file is created with mode ``0o666`` and the kernel applies the
user's umask, so the result has the same permissions as any other file the user creates
(``tempfile.mkstemp`` would make it private, 0600).
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import IO

#: Permission bits asked for; the process umask is taken off by the kernel.
FILE_MODE = 0o666
_TEMP_ATTEMPTS = 16


def _open_temporary(path: Path) -> tuple[int, Path]:
    for _ in range(_TEMP_ATTEMPTS):
        tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, FILE_MODE), tmp
        except FileExistsError:
            continue
    raise FileExistsError(f"{path.parent}: no free temporary name for {path.name}")


def _sync_folder(folder: Path) -> None:
    """Make the rename durable (best effort: some file systems cannot open folders)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write(path: str | os.PathLike[str], write: Callable[[IO[bytes]], object]) -> Path:
    """Write a file through ``write(handle)`` (a binary handle), atomically; returns the path.

    The folder is created if needed. On any exception (Ctrl-C too) the temporary file is
    removed and the previous file at ``path``, if any, is left as it was.
    """
    final = Path(path)
    final.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = _open_temporary(final)
    try:
        with os.fdopen(fd, "wb") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _sync_folder(final.parent)
    return final


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Write ``data`` atomically (see :func:`atomic_write`)."""
    return atomic_write(path, lambda handle: handle.write(data))


def atomic_write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write UTF-8 ``text`` atomically (see :func:`atomic_write`)."""
    return atomic_write_bytes(path, text.encode("utf-8"))
