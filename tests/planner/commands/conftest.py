"""Fixtures of the command tests."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest


@pytest.fixture
def no_dive(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """``sim`` stops where the dive would start (Ctrl-C, exit 130), for tests about reading a
    scenario; the list gets each prepared dive that reached it."""
    import planner.dryrun.dive as dive

    reached: list[Any] = []

    def fly(prepared: Any, out: Path, **_: Any) -> Any:
        reached.append(prepared)
        raise KeyboardInterrupt

    monkeypatch.setattr(dive, "dry_dive_into", fly)
    return reached
