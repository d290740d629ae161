"""What a recording file really is, from its first bytes, for messages that say so.

A ``.npz`` frame file is a zip archive; an ARIS recording starts with ``DDF\\x05``; a
lone NumPy array (``.npy``) with ``\\x93NUMPY``. :func:`file_kind` tells them apart, and
:func:`expect_kind` refuses a file whose content does not match its suffix with a message
that names what it is (an ``.aris`` renamed ``.npz`` is told so, instead of numpy's
advice about pickles).
"""

from __future__ import annotations

from pathlib import Path

from perception.errors import FrameFormatError

#: Leading bytes of each kind of file.
MAGIC = {
    "npz": (b"PK\x03\x04", b"PK\x05\x06"),
    "aris": (b"DDF\x05",),
    "npy": (b"\x93NUMPY",),
}
_WHAT = {
    "npz": "a .npz archive (zip)",
    "aris": "an ARIS recording (signature DDF\\x05)",
    "npy": "a single NumPy array (.npy), not a .npz archive of named arrays",
    "empty": "an empty file",
}
_SUFFIX = {"npz": ".npz", "aris": ".aris"}


def file_kind(path: str | Path) -> str:
    """``"npz"``, ``"aris"``, ``"npy"``, ``"empty"`` or ``"unknown"``, from the first bytes."""
    with open(path, "rb") as handle:
        head = handle.read(8)
    if not head:
        return "empty"
    for kind, magics in MAGIC.items():
        if any(head.startswith(m) for m in magics):
            return kind
    return "unknown"


def expect_kind(path: str | Path, wanted: str) -> None:
    """Refuse ``path`` unless its content is of kind ``wanted`` (``"npz"`` or ``"aris"``).

    Raises
    ------
    FrameFormatError
        Naming the file and what it holds instead; for a known other kind, the suffix it
        should have.
    """
    kind = file_kind(path)
    if kind == wanted:
        return
    if kind in _SUFFIX:
        raise FrameFormatError(f"holds {_WHAT[kind]}, not {_WHAT[wanted]}: give it the {_SUFFIX[kind]} suffix",
                               path=str(path))
    if kind in _WHAT:
        raise FrameFormatError(f"holds {_WHAT[kind]}, not {_WHAT[wanted]}", path=str(path))
    with open(path, "rb") as handle:
        head = handle.read(8)
    raise FrameFormatError(f"not {_WHAT[wanted]}: it starts with the bytes {head!r}", path=str(path))
