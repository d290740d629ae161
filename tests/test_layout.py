"""The layout rules of CONTRIBUTING.md, checked on the tree: no import cycles among the
four packages' modules, no module over 400 lines without its reason at the top, OpenCV
only behind ``perception.imaging``, and the import directions of architecture.md.

``python -m tests.test_layout`` prints the figures (largest module, modules over 400
lines, top-level modules per package, cycles)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("perception", "planner", "vehicle_link", "sim_harness")
MAX_LINES = 400
REASON_MARK = "(Over 400 lines:"


def _modules() -> dict[str, Path]:
    out = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            out[name.removesuffix(".__init__")] = path
    return out


def _imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """Modules of the four packages that ``path`` imports (anywhere in it, type-checking ones too)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return {n for n in names if n in modules}


def import_graph() -> dict[str, set[str]]:
    modules = _modules()
    # A module importing its own package's __init__ (or a parent's) is not an edge of a cycle.
    return {m: {t for t in _imports(p, modules) if t != m and not m.startswith(t + ".")} for m, p in modules.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (iterative Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def _lines(path: Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def test_no_import_cycles() -> None:
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]  # the detector finds one
    assert cycles(import_graph()) == []


def test_a_module_over_400_lines_says_why_at_its_top() -> None:
    long = {m: p for m, p in _modules().items() if _lines(p) > MAX_LINES}
    head = {m: "\n".join(p.read_text(encoding="utf-8").splitlines()[:12]) for m, p in long.items()}
    without = [m for m, text in head.items() if REASON_MARK not in text]
    assert without == []


def test_opencv_is_imported_in_perception_only_by_its_wrapper() -> None:
    users = [m for m, p in _modules().items() if m.startswith("perception") and "cv2" in _imports_any(p)]
    assert users == ["perception.imaging"]


def _imports_any(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize(("package", "never"), [
    ("perception", ("planner", "vehicle_link", "sim_harness")),
    ("vehicle_link", ("planner", "perception", "sim_harness")),
])
def test_the_lower_packages_never_import_the_others(package: str, never: tuple[str, ...]) -> None:
    offenders = {m: sorted(t for t in targets if t.split(".")[0] in never)
                 for m, targets in import_graph().items() if m.startswith(package + ".") or m == package}
    assert {m: t for m, t in offenders.items() if t} == {}


def figures() -> dict[str, object]:
    """The layout issue's figures for the current tree."""
    modules = _modules()
    sizes = sorted(((_lines(p), m) for m, p in modules.items()), reverse=True)
    top = {pkg: sorted(p.name for p in (ROOT / pkg).glob("*.py") if p.name != "__init__.py") for pkg in PACKAGES}
    return {"largest module": sizes[0], "modules over 400 lines": [s for s in sizes if s[0] > MAX_LINES],
            "top-level modules": {k: len(v) for k, v in top.items()}, "import cycles": cycles(import_graph())}


if __name__ == "__main__":
    for key, value in figures().items():
        print(f"{key}: {value}")
