"""Fuzzed machine files: every one loads into a usable machine or is refused in one line.

Mutations of the shipped files as a careless user or an attacker makes them: values swapped for
extreme numbers, NaN, huge integers, strings, booleans, tables; keys renamed; axis headers
renamed or repeated; bytes cut, added or re-encoded. 3 000 seeded mutations run in the default
suite (the must-show figure), and hypothesis explores further.
"""

from __future__ import annotations

import random
import re

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from retrofit.errors import ConfigError
from retrofit.machine.config import list_machines, load_machine, machines_dir

TEXTS = {name: (machines_dir() / f"{name}.toml").read_text() for name in list_machines()}
NAMES = sorted(TEXTS)
VALUE = re.compile(r"(?m)^(\s*[A-Za-z_][\w-]*\s*=\s*)([^#\n]*)")
HEADER = re.compile(r"(?m)^\[axis\.(\w+)\]")

EXTREMES = ["-1e308", "1e308", "1.8e308", "-1.8e308", "nan", "inf", "-inf", "0", "-0.0", "1e-320",
            "9" * 40, "-" + "9" * 40, "2147483648", "-2147483649", "1e9", "1.000001e9", "true",
            '""', '"X Y"', "[]", "[1, 2]", "{}", "{ x = 1 }", "1979-05-27", '"\u2028"', "0x7F",
            "'\x00'", "-1", "1", "0.5", "65536", "4294967296"]
HEADERS = ["", '""', '"X Y"', "1", "Q", "X", "x", "W", "w", "xx", "\u00c5", "Z", "a"]


def mutate(text: str, rng: random.Random) -> bytes:
    """One to three mutations of a machine file's text; the file's bytes."""
    for _ in range(rng.randint(1, 3)):
        kind = rng.random()
        if kind < 0.5:
            spots = list(VALUE.finditer(text))
            m = rng.choice(spots)
            text = text[:m.start(2)] + rng.choice(EXTREMES) + text[m.end(2):]
        elif kind < 0.65:
            heads = list(HEADER.finditer(text))
            if heads:
                m = rng.choice(heads)
                text = text[:m.start(1)] + rng.choice(HEADERS) + text[m.end(1):]
        elif kind < 0.75:
            start = text.find("[axis.")
            end = text.find("\n[", start + 1)
            if start >= 0 and end > start:
                text = text[:end] + "\n" + text[start:end] + text[end:]     # an axis twice
        elif kind < 0.85:
            i = rng.randrange(len(text))
            text = text[:i] + text[i + rng.randint(1, 40):]                  # a cut
        else:
            i = rng.randrange(len(text))
            text = text[:i] + rng.choice(["=", "[", "\n[axis]\n", "\x00", "\"", "\\u"]) + text[i:]
    encoding = rng.choice(["utf-8"] * 8 + ["utf-16", "latin-1"])
    return text.encode(encoding, "replace")


def check_one(path) -> str:
    """Load ``path``: "ok" for a usable machine, "refused" for a one-line ConfigError."""
    try:
        machine = load_machine(path)
    except ConfigError as exc:
        message = str(exc)
        assert "\n" not in message and path.name in message.split(": ")[0], message
        return "refused"
    for axis in machine.axes:                   # everything the core derives stays representable
        assert axis.name in "XYZABCUVWE" and len(axis.name) == 1
        assert isinstance(axis.min_steps, int) and isinstance(axis.max_steps, int)
        assert abs(axis.min_steps) < 2**31 and abs(axis.max_steps) < 2**31
        assert axis.max_velocity_mm_s * axis.steps_per_mm < float("inf")
    assert len(set(machine.axis_names)) == len(machine.axes)
    assert machine.ticks(1.0) > 0
    return "ok"


def test_three_thousand_fuzzed_machine_files_load_or_are_refused_in_one_line(tmp_path):
    rng = random.Random(14)
    outcomes = {"ok": 0, "refused": 0}
    for i in range(3000):
        name = NAMES[i % len(NAMES)]
        path = tmp_path / f"fuzz-{i}.toml"
        path.write_bytes(mutate(TEXTS[name], rng))
        outcomes[check_one(path)] += 1
    assert outcomes["refused"] > 1500 and outcomes["ok"] > 100, outcomes


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(NAMES), data=st.data())
def test_any_value_in_any_key_loads_or_is_refused_in_one_line(tmp_path, name, data):
    text = TEXTS[name]
    spots = list(VALUE.finditer(text))
    m = data.draw(st.sampled_from(spots))
    value = data.draw(st.one_of(
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.integers(min_value=-(10**30), max_value=10**30).map(str),
        st.text(max_size=8).map(lambda s: '"' + s.replace("\\", "/").replace('"', "'") + '"'),
        st.booleans().map(lambda b: "true" if b else "false")))
    value = {"nan": "nan", "inf": "inf", "-inf": "-inf"}.get(value, value)
    path = tmp_path / "h.toml"
    path.write_text(text[:m.start(2)] + value + text[m.end(2):])
    check_one(path)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(raw=st.binary(max_size=300))
def test_any_bytes_are_refused_in_one_line(tmp_path, raw):
    path = tmp_path / "bytes.toml"
    path.write_bytes(raw)
    assert check_one(path) == "refused"
