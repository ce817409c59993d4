"""Expressions and parameter references, read from a line's code and evaluated later.

The lexer reads a word's value as a small tree and the interpreter evaluates it each time the
line runs (a line inside a loop runs many times). A tree is either a float (a plain number) or a
tuple whose first item says what it is:

* ``("#", tree)`` numbered parameter, ``("#<", name)`` named parameter;
* ``("neg", tree)``; ``("fn", name, tree)`` a function; ``("atan", a, b)``; ``("exists", name)``;
* ``("op", operator, left, right)`` a binary operation.

Operators, from the tightest binding: ``**``; ``*  /  MOD``; ``+  -``; ``EQ NE GT GE LT LE``;
``AND OR XOR`` -- the order LinuxCNC uses. Angles are in degrees::

    >>> tree, end = read_value("[2+3*#1]", 0)
    >>> evaluate(tree, lambda ref: 4.0)
    14.0
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable

from .errors import RuleError

NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)")
_NAME = re.compile(r"<([^>]*)>")
FUNCTIONS = ("ABS", "ACOS", "ASIN", "ATAN", "COS", "EXISTS", "EXP", "FIX", "FUP", "LN", "ROUND",
             "SIN", "SQRT", "TAN")
#: binary operators by precedence level (higher binds tighter)
LEVELS = {"**": 4, "*": 3, "/": 3, "MOD": 3, "+": 2, "-": 2,
          "EQ": 1, "NE": 1, "GT": 1, "GE": 1, "LT": 1, "LE": 1, "AND": 0, "OR": 0, "XOR": 0}
_OPERATORS = sorted(LEVELS, key=len, reverse=True)


def read_value(code: str, pos: int) -> tuple[object, int]:
    """A real value at ``code[pos:]`` (upper case, no spaces): number, ``#``, ``[...]`` or function.

    Returns (tree, position after it). Raises RuleError when no value starts there.
    """
    if pos >= len(code):
        raise RuleError("a value is missing at the end of the line")
    ch = code[pos]
    if ch in "+-" and pos + 1 < len(code) and code[pos + 1] in "#[ABCDEFGHIJKLMNOPQRSTUVWXYZ":
        tree, pos = read_value(code, pos + 1)
        return (("neg", tree) if ch == "-" else tree), pos
    if ch == "[":
        return read_expression(code, pos)
    if ch == "#":
        return read_parameter(code, pos)
    if "A" <= ch <= "Z":
        return _read_function(code, pos)
    match = NUMBER.match(code, pos)
    if match is None:
        raise RuleError(f"bad number starting {code[pos:pos + 8]!r} (a value is a number such as "
                        f"-12.5, a #parameter or an [expression])")
    return float(match.group()), match.end()


def read_parameter(code: str, pos: int) -> tuple[object, int]:
    """``#n``, ``#[expr]``, ``##n`` or ``#<name>`` starting at ``code[pos] == '#'``."""
    if code.startswith("<", pos + 1):
        match = _NAME.match(code, pos + 1)
        if match is None:
            raise RuleError("named parameter '#<' is not closed with '>'")
        return ("#<", match.group(1).lower()), match.end()
    index, end = read_value(code, pos + 1)
    return ("#", index), end


def read_expression(code: str, pos: int) -> tuple[object, int]:
    """``[ value op value op ... ]`` starting at ``code[pos] == '['``, by operator precedence."""
    values: list[object] = []
    ops: list[str] = []
    pos += 1
    while True:
        tree, pos = read_value(code, pos)
        values.append(tree)
        if pos >= len(code):
            raise RuleError("expression '[' is not closed with ']'")
        if code[pos] == "]":
            break
        op = next((o for o in _OPERATORS if code.startswith(o, pos)), None)
        if op is None:
            raise RuleError(f"unknown operator {code[pos:pos + 4]!r} in expression (operators: "
                            f"{' '.join(LEVELS)})")
        while ops and LEVELS[ops[-1]] >= LEVELS[op]:
            _reduce(values, ops)
        ops.append(op)
        pos += len(op)
    while ops:
        _reduce(values, ops)
    return values[0], pos + 1


def _reduce(values: list, ops: list) -> None:
    right, left = values.pop(), values.pop()
    values.append(("op", ops.pop(), left, right))


def _read_function(code: str, pos: int) -> tuple[object, int]:
    name = next((f for f in FUNCTIONS if code.startswith(f, pos)), None)
    if name is None:
        raise RuleError(f"unknown function or word {code[pos:pos + 5]!r} where a value was "
                        f"expected (functions: {' '.join(FUNCTIONS)})")
    pos += len(name)
    if not code.startswith("[", pos):
        raise RuleError(f"{name} needs its argument in brackets, e.g. {name}[30]")
    if name == "EXISTS":
        match = re.compile(r"\[#<([^>]*)>\]").match(code, pos)
        if match is None:
            raise RuleError("EXISTS takes a named parameter: EXISTS[#<name>]")
        return ("exists", match.group(1).lower()), match.end()
    arg, pos = read_expression(code, pos)
    if name == "ATAN":
        if not code.startswith("/[", pos):
            raise RuleError("ATAN takes two arguments: ATAN[y]/[x]")
        second, pos = read_expression(code, pos + 1)
        return ("atan", arg, second), pos
    return ("fn", name, arg), pos


Lookup = Callable[[object], float]


def evaluate(tree, lookup: Lookup, exists: Callable[[str], bool] = lambda n: False) -> float:
    """The value of ``tree``; ``lookup(ref)`` reads a parameter (``ref`` an index or a name)."""
    if type(tree) is float:
        return tree
    kind = tree[0]
    if kind == "#":
        return lookup(evaluate(tree[1], lookup, exists))
    if kind == "#<":
        return lookup(tree[1])
    if kind == "neg":
        return -evaluate(tree[1], lookup, exists)
    if kind == "op":
        return _operate(tree[1], evaluate(tree[2], lookup, exists), evaluate(tree[3], lookup, exists))
    if kind == "fn":
        return _function(tree[1], evaluate(tree[2], lookup, exists))
    if kind == "atan":
        return math.degrees(math.atan2(evaluate(tree[1], lookup, exists),
                                       evaluate(tree[2], lookup, exists)))
    return 1.0 if exists(tree[1]) else 0.0


def _operate(op: str, a: float, b: float) -> float:
    try:
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if op == "/":
            if b == 0.0:
                raise RuleError("attempt to divide by zero in an expression")
            return a / b
        if op == "**":
            if a < 0.0 and not float(b).is_integer():
                raise RuleError(f"attempt to raise negative {a:g} to non-integer power {b:g}")
            return float(a ** b)
        if op == "MOD":
            if b == 0.0:
                raise RuleError("MOD by zero in an expression")
            return math.fmod(a, b) if a * b >= 0 else a - b * math.floor(a / b)
    except OverflowError:
        raise RuleError(f"the expression overflows ({a:g} {op} {b:g})") from None
    return float(_COMPARE[op](a, b))


_COMPARE = {"EQ": lambda a, b: a == b, "NE": lambda a, b: a != b, "GT": lambda a, b: a > b,
            "GE": lambda a, b: a >= b, "LT": lambda a, b: a < b, "LE": lambda a, b: a <= b,
            "AND": lambda a, b: a != 0 and b != 0, "OR": lambda a, b: a != 0 or b != 0,
            "XOR": lambda a, b: (a != 0) != (b != 0)}


def _function(name: str, x: float) -> float:
    if name in ("ACOS", "ASIN") and not -1.0 <= x <= 1.0:
        raise RuleError(f"argument to {name} out of range: {x:g} (needs -1..1)")
    if name == "LN" and not x > 0.0:
        raise RuleError(f"zero or negative argument to LN: {x:g}")
    if name == "SQRT" and x < 0.0:
        raise RuleError(f"negative argument to SQRT: {x:g}")
    if not math.isfinite(x):
        raise RuleError(f"argument to {name} is not a finite number")
    try:
        if name == "ABS":
            return abs(x)
        if name == "ACOS":
            return math.degrees(math.acos(x))
        if name == "ASIN":
            return math.degrees(math.asin(x))
        if name == "COS":
            return math.cos(math.radians(x))
        if name == "SIN":
            return math.sin(math.radians(x))
        if name == "TAN":
            return math.tan(math.radians(x))
        if name == "EXP":
            return math.exp(x)
        if name == "FIX":
            return float(math.floor(x))
        if name == "FUP":
            return float(math.ceil(x))
        if name == "LN":
            return math.log(x)
        if name == "ROUND":
            return float(math.floor(abs(x) + 0.5)) * (1.0 if x >= 0 else -1.0)
        return math.sqrt(x)
    except OverflowError:
        raise RuleError(f"{name}[{x:g}] overflows") from None
