"""Typed reads from one table of a TOML settings file, each error naming the file and key.

:class:`SettingsTable` wraps a parsed table (``survey.toml``'s ``[vehicle]``, a scenario's
``[faults]``...) and reads its keys as finite numbers within bounds, whole numbers,
booleans, strings from a list of choices or lists of time windows; every read remembers
the key, and :meth:`SettingsTable.finish` refuses any key that was never read (a
misspelling). Every error is a :class:`~planner.errors.ConfigError` that names the file
and the full key (``"faults.packet_loss"``).
"""

from __future__ import annotations

import math
from typing import Any

from planner.errors import ConfigError


class SettingsTable:
    """Typed reads from one TOML table that remember which keys were used.

    Parameters
    ----------
    data : Any
        The parsed table (anything else than a dict is refused, naming ``name``).
    name : str
        Its name in the file (``"vehicle"``), the prefix of every key in messages.
    path : str or None
        The file, for messages.
    """

    def __init__(self, data: Any, name: str, path: str | None):
        if not isinstance(data, dict):
            raise ConfigError(f"must be a table, got {data!r:.40}", key=name, path=path)
        self.data, self.name, self.path = data, name, path
        self.used: set[str] = set()

    def _key(self, key: str) -> str:
        return f"{self.name}.{key}" if self.name else key

    def error(self, key: str, message: str) -> ConfigError:
        """A :class:`ConfigError` for ``key`` of this table."""
        return ConfigError(message, key=self._key(key), path=self.path)

    def has(self, key: str) -> bool:
        """Whether the table gives ``key``."""
        return key in self.data

    def _get(self, key: str, default: Any) -> Any:
        self.used.add(key)
        if key not in self.data:
            if default is None:
                raise self.error(key, "missing")
            return default
        return self.data[key]

    def number(
        self,
        key: str,
        *,
        lo: float | None = None,
        hi: float | None = None,
        lo_open: bool = False,
        default: float | None = None,
    ) -> float:
        """A finite number within ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""
        value = self._get(key, default)
        if default is not None and key not in self.data:
            return float(default)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(key, f"must be a number, got {value!r:.40}")
        v = float(value)
        if not math.isfinite(v):
            raise self.error(key, f"must be finite, got {value!r}")
        if lo is not None and (v <= lo if lo_open else v < lo):
            raise self.error(key, f"must be {'>' if lo_open else '>='} {lo:g}, got {v:g}")
        if hi is not None and v > hi:
            raise self.error(key, f"must be <= {hi:g}, got {v:g}")
        return v

    def integer(self, key: str, *, lo: int, hi: int, default: int | None = None) -> int:
        """A whole number (a TOML integer, not ``1.0`` or ``true``) within ``[lo, hi]``."""
        value = self._get(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"must be a whole number, got {value!r:.40}")
        if not lo <= value <= hi:
            raise self.error(key, f"must be within {lo}..{hi}, got {value}")
        return int(value)

    def boolean(self, key: str, *, default: bool | None = None) -> bool:
        """``true`` or ``false``."""
        value = self._get(key, default)
        if not isinstance(value, bool):
            raise self.error(key, f"must be true or false, got {value!r:.40}")
        return value

    def string(self, key: str, choices: tuple[str, ...] | None = None, *, default: str | None = None) -> str:
        """A string; one of ``choices`` when given."""
        value = self._get(key, default)
        if not isinstance(value, str) or (choices is not None and value not in choices):
            allowed = f"one of {', '.join(choices)}" if choices is not None else "a string"
            raise self.error(key, f"must be {allowed}; got {value!r:.40}")
        return value

    def windows(self, key: str, *, hi: float) -> tuple[tuple[float, float], ...]:
        """A list of ``[start_s, end_s]`` pairs, ``0 <= start_s <= end_s <= hi``."""
        if key not in self.data:
            self.used.add(key)
            return ()
        value = self._get(key, None)
        if not isinstance(value, list):
            raise self.error(key, f"must be a list of [start_s, end_s] pairs, got {value!r:.40}")
        out = []
        for i, pair in enumerate(value):
            if (not isinstance(pair, list) or len(pair) != 2
                    or any(isinstance(v, bool) or not isinstance(v, int | float) for v in pair)):
                raise self.error(f"{key}[{i}]", f"must be a [start_s, end_s] pair of numbers, got {pair!r:.40}")
            start, end = float(pair[0]), float(pair[1])
            if not (math.isfinite(start) and math.isfinite(end) and 0.0 <= start <= end <= hi):
                raise self.error(f"{key}[{i}]", f"must satisfy 0 <= start_s <= end_s <= {hi:g}, got {pair!r}")
            out.append((start, end))
        return tuple(out)

    def integers(self, key: str, *, lo: int, hi: int) -> tuple[int, ...]:
        """A list of whole numbers within ``[lo, hi]``."""
        if key not in self.data:
            self.used.add(key)
            return ()
        value = self._get(key, None)
        if not isinstance(value, list):
            raise self.error(key, f"must be a list of whole numbers, got {value!r:.40}")
        for i, v in enumerate(value):
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise self.error(f"{key}[{i}]", f"must be a whole number within {lo}..{hi}, got {v!r:.40}")
        return tuple(value)

    def finish(self) -> None:
        """Refuse the first key that was never read (a misspelling)."""
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            allowed = ", ".join(sorted(self.used))
            raise self.error(unknown[0], f"unknown setting (check the spelling; allowed: {allowed})")
