"""Output folders that never lose anything: built aside, moved into place when whole.

A command that writes a folder (``sim``, ``run`` and ``plan`` ``--out``, ``mosaic --out``,
``site DIR``) goes through :func:`staged_folder`:

1. **Check first.** An existing folder that holds anything is refused unless the user
   passed ``--overwrite``; even then only a folder this product wrote (it holds one of
   the command's marker files: ``summary.json`` or ``events.jsonl`` for a run,
   ``plan.json`` for a plan, ``mosaic.tif`` for a map, ``scenario.toml`` for a
   scenario) is replaced, never a folder of someone's own files.
2. **Build aside.** The command writes into a new sibling folder ``.NAME.partial-XXXX``
   (same parent, so same file system), never into the old one.
3. **Move into place.** When the command finishes, the old folder (if any) is renamed
   away, the new one renamed to ``NAME`` and the old one deleted.
4. **On a crash, Ctrl-C or a refusal** the old folder is left untouched, byte for byte.
   The new folder is kept, marked partial: ``on_failure`` writes why (a run's
   ``summary.json`` gets ``"status": "partial"`` and the reason), and it is moved to
   ``NAME`` if there was nothing there, else to ``NAME.partial`` (``NAME.partial-2``, ...)
   beside it. The exception goes on, carrying a note that says where the partial
   folder is (:mod:`planner.cli` prints it on the same line).

Validation that can refuse the input (a scenario, an area, settings) runs before
:func:`staged_folder` is entered, so a refusal touches no folder at all.
"""

from __future__ import annotations

import os
import secrets
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from planner.errors import OutputFolderError

#: Marker files by kind of folder: an existing folder holding one of them was written by
#: this product and may be replaced with ``--overwrite``.
MARKERS: dict[str, tuple[str, ...]] = {
    "run": ("summary.json", "events.jsonl"),
    "plan": ("plan.json",),
    "map": ("mosaic.tif", "targets.geojson"),
    "scenario": ("scenario.toml",),
}


def check_output_folder(out: Path, *, kind: str, overwrite: bool, option: str = "--out") -> None:
    """Refuse ``out`` when writing it would overwrite something (see the module docstring).

    Raises
    ------
    OutputFolderError
        When ``out`` is a file, a non-empty folder without ``overwrite``, or (even with
        ``overwrite``) a folder this product did not write.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputFolderError(f"{option} {out}: exists and is not a folder")
    if not out.is_dir():
        return
    held = sorted(p.name for p in out.iterdir())
    if not held:
        return
    markers = MARKERS[kind]
    ours = any((out / m).exists() for m in markers)
    if not overwrite:
        what = f"a {kind} folder" if ours else "files"
        raise OutputFolderError(f"{option} {out}: already holds {what} ({', '.join(held[:4])}"
                                f"{', ...' if len(held) > 4 else ''}); pass --overwrite to replace it, or choose "
                                "another folder")
    if not ours:
        raise OutputFolderError(f"{option} {out}: holds files that are not a shadowsurvey {kind} folder (no "
                                f"{' or '.join(markers)}: {', '.join(held[:4])}); not replacing it, even with "
                                "--overwrite")


def _sibling(out: Path, tag: str) -> Path:
    return out.parent / f".{out.name}.{tag}-{secrets.token_hex(4)}"


def _free_partial_name(out: Path) -> Path:
    candidate = out.with_name(f"{out.name}.partial")
    k = 2
    while candidate.exists():
        candidate = out.with_name(f"{out.name}.partial-{k}")
        k += 1
    return candidate


def _commit(stage: Path, out: Path) -> None:
    if out.is_dir():
        old = _sibling(out, "old")
        os.rename(out, old)
        os.rename(stage, out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.rename(stage, out)


def _keep_partial(stage: Path, out: Path) -> Path:
    if out.is_dir() and not any(out.iterdir()):
        out.rmdir()
    target = out if not out.exists() else _free_partial_name(out)
    os.rename(stage, target)
    return target


@contextmanager
def staged_folder(out: Path, *, kind: str, overwrite: bool,
                  on_failure: Callable[[Path, BaseException], object] | None = None,
                  keep_partial: bool = True, option: str = "--out") -> Iterator[Path]:
    """Yield a fresh folder to build ``out`` in; move it into place on success.

    ``on_failure(stage, exc)`` is called before a failed folder is kept as partial (write
    there why it is partial). With ``keep_partial`` False (a plan: half a plan must never
    be flown) a failed folder is deleted instead. See the module docstring for every case.
    """
    check_output_folder(Path(out), kind=kind, overwrite=overwrite, option=option)
    out = Path(out).resolve()  # "." or "runs/.." named by what they are, so the sibling is beside them
    out.parent.mkdir(parents=True, exist_ok=True)
    stage = _sibling(out, "partial")
    stage.mkdir()
    try:
        yield stage
    except BaseException as exc:
        if not keep_partial:
            shutil.rmtree(stage, ignore_errors=True)
            exc.add_note(f"nothing written; {out} untouched" if out.exists() else "nothing written")
            raise
        try:
            if on_failure is not None:
                on_failure(stage, exc)
            kept = _keep_partial(stage, out)
        except Exception as inner:  # never hide the first failure behind a second one
            exc.add_note(f"the partial folder {stage} could not be marked or moved ({inner})")
            raise
        exc.add_note(f"partial {kind} folder kept in {kept}"
                     + ("" if kept == out else f"; {out} untouched"))
        raise
    _commit(stage, out)
