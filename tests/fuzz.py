"""Hypothesis strategies that damage valid inputs, and the command line's input contract.

The contract every command keeps for any input it reads (the property tests check it):
exit code 0 with a result, or exit code 2 with exactly ONE line on stderr that names the
file or the option at fault; never a traceback, never exit code 1 for bad input.
"""

from __future__ import annotations

import io
import json
import re
import tempfile
from collections.abc import Callable, Sequence
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from planner.cli import main

#: TOML values that have broken readers: wrong types, non-finite and huge numbers, nesting.
TOML_VALUES = ('"fast"', "[1, 2]", "nan", "-nan", "inf", "-inf", "-5", "0", "1e308", "-1e308", "1e-320",
               "99999999999999999999", "-1", "true", "false", '""', "{ a = 1 }", "[]", "[[1, 2], [3]]",
               "1979-05-27T07:32:00Z", "07:32:00", '"\u65e5\u672c"', "0.1", "3", '"auto"', '"surface"',
               "[[0, 1e9]]", "[[-1, 2]]", '["a"]', "[true]", "1.5", "-0.0")


@st.composite
def mutated_bytes(draw: Any, data: bytes, *, max_ops: int = 4) -> bytes:
    """``data`` with a few byte flips, deletions, insertions, duplications or a truncation."""
    out = bytearray(data)
    for _ in range(draw(st.integers(1, max_ops))):
        op = draw(st.sampled_from(("flip", "delete", "insert", "truncate", "duplicate", "overwrite")))
        at = draw(st.integers(0, max(len(out) - 1, 0)))
        if op == "flip" and out:
            out[at] ^= 1 << draw(st.integers(0, 7))
        elif op == "delete" and out:
            del out[at:at + draw(st.integers(1, 16))]
        elif op == "insert":
            out[at:at] = draw(st.binary(min_size=1, max_size=16))
        elif op == "truncate":
            del out[at:]
        elif op == "duplicate" and out:
            out[at:at] = out[at:at + draw(st.integers(1, 64))]
        elif op == "overwrite" and out:
            chunk = draw(st.binary(min_size=1, max_size=8))
            out[at:at + len(chunk)] = chunk
    return bytes(out)


def _json_containers(inner: st.SearchStrategy[Any]) -> st.SearchStrategy[Any]:
    return st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4)


#: Any JSON value, small.
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-10**20, 10**20) | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8),
    _json_containers,
    max_leaves=8,
)


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i))
    return out


@st.composite
def mutated_json(draw: Any, doc: Any) -> Any:
    """``doc`` (parsed JSON) with one to three nodes below the root replaced by any JSON value, or deleted."""
    doc = json.loads(json.dumps(doc))
    for _ in range(draw(st.integers(1, 3))):
        paths = _paths(doc)
        path = draw(st.sampled_from(paths[1:] or paths))  # the root itself only when it is all there is
        if not path:
            return draw(JSON_VALUES)
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        if draw(st.booleans()) and isinstance(parent, dict):
            del parent[path[-1]]
        else:
            parent[path[-1]] = draw(JSON_VALUES)
    return doc


_ASSIGNMENT = re.compile(r"^(\s*[A-Za-z0-9_.\"-]+\s*=\s*)(.*)$")


@st.composite
def mutated_toml(draw: Any, text: str) -> str:
    """``text`` (TOML) with values replaced by troublesome ones, lines dropped, keys or tables renamed."""
    lines = text.splitlines()
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(("value", "value", "value", "drop", "rename", "junk")))
        match = _ASSIGNMENT.match(lines[i])
        if op == "value" and match:
            value = draw(st.sampled_from(TOML_VALUES) | st.text(max_size=6).map(json.dumps))
            lines[i] = match.group(1) + value
        elif op == "drop":
            del lines[i]
            if not lines:
                lines = [""]
        elif op == "rename" and match:
            lines[i] = "x" + lines[i].lstrip()
        elif op == "junk":
            lines[i] = draw(st.sampled_from(("[vehicle]", "[[faults]]", "vehicle = 3", "= 1", "[x.y]", "a.b = 1",
                                             "faults = [1, 2]", 'vehicle = "fast"')))
    return "\n".join(lines) + "\n"


def check_reader(read: Callable[[Path], object], path: Path) -> None:
    """``read(path)`` returns, or raises a ValueError/OSError naming ``path`` (the readers' contract)."""
    try:
        read(path)
    except (ValueError, OSError) as exc:
        assert str(path) in str(exc), str(exc)


def file_case(name: str, data: str | bytes, read: Callable[[Path], object],
              argv: Callable[[Path, Path], Sequence[str]], names: Sequence[str] = ()) -> None:
    """``data`` written to a temporary file ``name``: through ``read`` (:func:`check_reader`), then
    through ``shadowsurvey argv(file, temporary folder)`` (:func:`assert_contract`, naming the file or
    one of ``names``)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / name
        path.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
        check_reader(read, path)
        code, _, err = run_cli(argv(path, Path(tmp)))
        assert_contract(code, err, [str(path), *names])


def run_cli(argv: Sequence[str]) -> tuple[int, str, str]:
    """``shadowsurvey ARGV`` in this process: (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


def assert_contract(code: int, err: str, names: Sequence[str]) -> None:
    """Exit 0, or exit 2 with one stderr line that names one of ``names`` (files or options)."""
    assert code in (0, 2), f"exit {code}: {err}"
    if code == 2:
        assert err.endswith("\n") and err.count("\n") == 1, f"not one line: {err!r}"
        assert "Traceback" not in err
        assert any(n in err for n in names), f"names none of {list(names)}: {err!r}"
