"""Helpers for the labs' checks: seeded random cases a student can draw again, and a look at the
student's source for library functions that would hand over the answer the lab asks for.

Every check that draws cases takes them from :func:`cases`, seeded by the check's name and
``RETROFIT_CHECK_SEED`` (default 2024), so a grade is the same on every run and a failure message
ends with :func:`seed_note`, which tells the student how to draw the same cases again.
"""

from __future__ import annotations

import ast
import os
import random
from pathlib import Path

from ..errors import ConfigError

SEED_ENV = "RETROFIT_CHECK_SEED"
DEFAULT_SEED = 2024


def seed() -> int:
    """The seed of this run's cases: ``RETROFIT_CHECK_SEED`` if set, else :data:`DEFAULT_SEED`."""
    text = os.environ.get(SEED_ENV, "")
    try:
        return int(text) if text else DEFAULT_SEED
    except ValueError:
        raise ConfigError(f"{SEED_ENV}={text}: not a whole number; give the seed of the checks' cases, "
                          f"e.g. {DEFAULT_SEED}") from None


def cases(name: str) -> random.Random:
    """The random source of one check, named ``name``: the same cases for the same seed."""
    return random.Random(f"{seed()}:{name}")


def seed_note() -> str:
    """'cases drawn with seed 2024 (RETROFIT_CHECK_SEED=2024 draws them again)', for failure messages."""
    return f"cases drawn with seed {seed()} ({SEED_ENV}={seed()} draws them again)"


def borrowed(path: str | Path, answers: dict[str, set[str]], within: set[str] | None = None,
             methods: frozenset[str] = frozenset(), strings: bool = True) -> list[str]:
    """Where the file at ``path`` reaches for a library function that is the answer itself.

    ``answers`` maps a module to the names in it a student must not call (``{"retrofit.demo":
    {"circle_targets"}}``); an empty set forbids the whole module. Found: ``from M import name``,
    ``import M`` (or its package) followed by ``M.name``, and the module's name in a string (an
    ``importlib`` call). With ``within`` (names of the file's functions and classes), only those and
    what they call of the file's own are read: the lab's given code may import the library for its
    plots. ``methods`` are attribute names that are answers on whatever object they are read
    (``motor.max_accel_steps_s2``); ``strings=False`` leaves names written in strings alone (a file
    that lists the answers, as the checks do). Returns one 'line N: ...' per place.
    """
    try:
        tree = ast.parse(Path(path).read_text(encoding="utf-8"))
    except (OSError, SyntaxError, ValueError):
        return []
    aliases = _aliases(tree)
    places = []
    for node in _nodes(tree, within):
        if isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                if _forbidden(node.module, alias.name, answers) or _forbidden(f"{node.module}.{alias.name}", "*",
                                                                                    answers):
                    places.append(f"line {node.lineno}: from {node.module} import {alias.name}")
        elif isinstance(node, ast.Import):
            places += [f"line {node.lineno}: import {a.name}" for a in node.names if _forbidden(a.name, "*", answers)]
        elif isinstance(node, ast.Attribute) and node.attr in methods:
            places.append(f"line {node.lineno}: .{node.attr}")
        elif isinstance(node, ast.Attribute):
            dotted = _dotted(node, aliases)
            module, _, name = dotted.rpartition(".")
            if module and _forbidden(module, name, answers):
                places.append(f"line {node.lineno}: {dotted}")
        elif isinstance(node, ast.Name) and node.id in aliases:
            module, _, name = aliases[node.id].rpartition(".")
            if module and _forbidden(module, name, answers):
                places.append(f"line {node.lineno}: {node.id} ({aliases[node.id]})")
        elif strings and isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and (node.value in answers or node.value in methods):
            places.append(f"line {node.lineno}: {node.value!r}")
    return sorted(set(places), key=lambda p: int(p.split(":")[0][5:]))


def _nodes(tree: ast.Module, within: set[str] | None):
    """Every node of the file, or of the named top-level functions and classes and those they use."""
    if within is None:
        yield from ast.walk(tree)
        return
    defs = {node.name: node for node in tree.body
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))}
    defs.update({target.id: node for node in tree.body if isinstance(node, ast.Assign)
                 for target in node.targets if isinstance(target, ast.Name)})
    todo, seen = [name for name in within if name in defs], set()
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        for node in ast.walk(defs[name]):
            if isinstance(node, ast.Name) and node.id in defs and node.id not in seen:
                todo.append(node.id)
            yield node


def _aliases(tree: ast.AST) -> dict[str, str]:
    """Local name -> the module (or module.name) it stands for, from the file's imports."""
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                names[a.asname or a.name.partition(".")[0]] = a.name if a.asname else a.name.partition(".")[0]
        elif isinstance(node, ast.ImportFrom) and node.module:
            for a in node.names:
                names[a.asname or a.name] = f"{node.module}.{a.name}"
    return names


def _forbidden(module: str, name: str, answers: dict[str, set[str]]) -> bool:
    """``name`` of ``module`` is an answer ("*", the module itself: only when the whole module is); a module
    forbidden whole forbids its submodules too."""
    if any(not names and module.startswith(whole + ".") for whole, names in answers.items()):
        return True
    return module in answers and (not answers[module] or name in answers[module])


def _dotted(node: ast.AST, aliases: dict[str, str]) -> str:
    """``d.circle_targets`` after ``from retrofit import demo as d`` -> 'retrofit.demo.circle_targets'."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        return ".".join([aliases.get(node.id, node.id), *reversed(parts)])
    return ""
