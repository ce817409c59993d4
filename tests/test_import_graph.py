"""The house's import graph, read from the code (ast over retrofit/): no package imports a layer
above its own, and no packages import each other round a circle (docs/architecture.md)."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "retrofit"

#: lowest first; a unit (a package of retrofit/, or a module standing alone in it) may import its
#: own layer and those below
LAYERS = [
    {"errors", "atomic", "failsafe", "hold"},
    {"machine"},
    {"commands", "frames", "runlog"},
    {"backlash"},
    {"motion"},
    {"sim", "fpga"},
    {"link"},
    {"controller"},
    {"outputs"},
    {"canon"},
    {"gcode", "atc", "camlink"},
    {"firmware"},
    {"run"},
    {"console", "lab", "demo"},
    {"cli"},
]
LAYER = {unit: i for i, units in enumerate(LAYERS) for unit in units}
#: folders of data shipped with the package (machine files, example programs), not code
DATA = {"examples", "machines"}
#: imports known to break the rule, each with the module that makes it; take one off when it goes
KNOWN = {("gcode", "atc"): "retrofit/gcode/iowords.py"}


def unit_of(dotted: str) -> str | None:
    parts = dotted.split(".")
    return parts[1] if parts[0] == "retrofit" and len(parts) > 1 else None


def imports() -> dict[tuple[str, str], set[str]]:
    """(importing unit, imported unit) -> the files that import across, lazy imports included."""
    edges: dict[tuple[str, str], set[str]] = defaultdict(set)
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent)
        parts = list(rel.with_suffix("").parts)
        package = parts[:-1]                        # what a relative import starts from
        here = unit_of(".".join(parts))
        for node in ast.walk(ast.parse(path.read_text(), str(rel))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else []))
                targets = [f"{base}.{a.name}" for a in node.names]
            else:
                continue
            for target in targets:
                there = unit_of(target)
                if here and there and here != there:
                    edges[(here, there)].add(str(rel))
    return edges


EDGES = imports()


def test_every_unit_has_a_layer():
    units = {p.stem if p.suffix == ".py" else p.name for p in PACKAGE.iterdir()
             if (p.suffix == ".py" and p.stem != "__init__") or (p / "__init__.py").is_file()}
    assert units - set(LAYER) - DATA == set(), "give the new package a layer in LAYERS and docs/architecture.md"


def test_no_package_imports_a_layer_above_its_own():
    upward = {f"{a} (layer {LAYER[a]}) imports {b} (layer {LAYER[b]}) in {', '.join(sorted(files))}"
              for (a, b), files in EDGES.items() if LAYER[b] > LAYER[a] and (a, b) not in KNOWN}
    assert not upward, "\n".join(sorted(upward))


def cycles(edges) -> list[list[str]]:
    """Circles of the unit graph (each found once, from its smallest unit)."""
    graph = defaultdict(set)
    for a, b in edges:
        graph[a].add(b)
    found = []

    def walk(start, node, path):
        for nxt in sorted(graph[node]):
            if nxt == start:
                found.append(path + [start])
            elif nxt > start and nxt not in path:
                walk(start, nxt, path + [nxt])

    for start in sorted(graph):
        walk(start, start, [start])
    return found


def test_no_packages_import_each_other_round_a_circle():
    circles = cycles([e for e in EDGES if e not in KNOWN])
    assert not circles, "\n".join(" -> ".join(c) for c in circles)


def test_the_known_exceptions_are_still_there():
    for (a, b), where in KNOWN.items():
        assert where in EDGES.get((a, b), set()), f"{a} -> {b} is gone: take it off KNOWN"


@pytest.mark.parametrize("edges, expected", [
    ([("a", "b"), ("b", "c"), ("c", "a")], [["a", "b", "c", "a"]]),
    ([("a", "b"), ("b", "c")], []),
])
def test_the_circle_finder_finds_circles(edges, expected):
    assert cycles(edges) == expected
