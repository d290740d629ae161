"""Markdown building blocks of the dive report: values with units, safe table cells, tables, target names."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

#: Longest event message shown in a table cell, characters.
MESSAGE_CHARS = 240


def cell(text: Any) -> str:
    """Text made safe for a Markdown table cell (one line, pipes escaped)."""
    return " ".join(str(text).split()).replace("|", "\\|")


def short(text: str, limit: int = MESSAGE_CHARS) -> str:
    """``text`` cut to ``limit`` characters (a traceback in an event, say), marked with an ellipsis."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def fmt(value: Any, unit: str = "") -> str:
    """A value for the report: ``unit`` one of ``duration``, ``percent``, ``count``, ``cm``, ``""`` or a unit
    name (``m``, ``deg``); missing and non-finite values are a dash."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    if isinstance(value, bool) or not isinstance(value, int | float):
        return cell(str(value))
    if isinstance(value, int):
        return str(value)
    if unit == "duration":
        return f"{value:.1f} s ({value / 60:.1f} min)"
    if unit == "percent":
        return f"{100 * value:.1f} %"
    if unit == "count":
        return f"{value:g}"
    if unit == "cm":
        return f"{100 * value:.2f} cm"
    if unit == "":
        return f"{value:.1f}" if abs(value) >= 100 else f"{value:.4g}"
    return f"{value:.2f} {unit}"


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """A Markdown table (its lines, a blank line after)."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out + [""]


def truth_label(target_id: str) -> str:
    """How a true target is named in figures: ``T<id>`` for numeric ids, else the id itself."""
    return f"T{target_id}" if target_id[:1].isdigit() or not target_id else target_id
