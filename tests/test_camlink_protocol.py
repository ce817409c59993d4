"""CAM link (001): message parsing and formatting, the '@' splitter, [servo], trajectory rows, jobs."""

import math

import numpy as np
import pytest

from retrofit.camlink.job import path_job, program_job
from retrofit.camlink.protocol import (
    Auto,
    EndOperation,
    Home,
    Jog,
    JogFeed,
    LineSplitter,
    Machining,
    Operation,
    Row,
    Spindle,
    ToolChange,
    format_message,
    is_reply,
    parse_message,
    parse_position,
)
from retrofit.camlink.trajectory import arc_points, plan_rows
from retrofit.errors import ConfigError, LinkError
from retrofit.machine.config import load_machine

MILL = load_machine("grenoble-mill")

MESSAGES = [
    ("A", Auto()), ("JX", Jog("X")), ("JZ", Jog("Z")), ("M1", Machining(True)), ("M0", Machining(False)),
    ("P1", Operation(True)), ("P0", Operation(False)), ("#", EndOperation()), ("S150", Spindle(150)),
    ("F150", JogFeed(150)), ("T1 34", ToolChange(1, 34)), ("H", Home()),
    ("12 4500 -255 0 0 -3000", Row((12, -255, 0), (4500, 0, -3000))),
]


@pytest.mark.parametrize("text, message", MESSAGES, ids=[t for t, _ in MESSAGES])
def test_each_message_of_the_paper_parses_and_formats_back(text, message):
    assert parse_message(text.encode()) == message
    assert format_message(message) == f"{text}@".encode()


def test_whitespace_around_a_message_is_ignored():
    assert parse_message(b"\r\n  S150 \n") == Spindle(150)


BAD = [
    ("S256", "spindle speed 256 out of range; accepted 0..255"),
    ("F-1", "jog feedrate -1 out of range; accepted 0..255"),
    ("T1", "expected T<tool> <length mm>"),
    ("JW", "expected JX, JY or JZ"),
    ("M2", "expected M1 or M0"),
    ("1 2 3 4 5", "a row has 6 numbers"),
    ("256 0 0 0 0 0", "feedrate X 256 out of range; accepted -255..255"),
    ("0 1.5 0 0 0 0", "position X '1.5' is not a whole number"),
    ("0 0 0 99999999999 0 0", "position Y 99999999999 out of range"),
    ("G1 X5", "unknown command"),
    ("", "empty message"),
    ("A\x00", "byte 0x00 at column 2 is not printable ASCII"),
]


@pytest.mark.parametrize("text, why", BAD, ids=[repr(t) for t, _ in BAD])
def test_malformed_messages_are_refused_saying_why(text, why):
    with pytest.raises(LinkError) as info:
        parse_message(text.encode("latin-1"))
    assert why in str(info.value)


def test_splitter_rebuilds_messages_from_any_chunking():
    stream = b"A@M1@P1@S150@1 10 0 0 0 0@#@M0@"
    whole = LineSplitter().feed(stream)
    splitter = LineSplitter()
    bytewise = [m for i in range(len(stream)) for m in splitter.feed(stream[i:i + 1])]
    assert whole == bytewise == [b"A", b"M1", b"P1", b"S150", b"1 10 0 0 0 0", b"#", b"M0"]


def test_splitter_takes_256_bytes_and_refuses_257_then_carries_on():
    splitter = LineSplitter()
    ok = b" " * 255 + b"A"
    out = splitter.feed(ok + b"@" + b"x" * 257 + b"@H@")
    assert out[0] == ok
    assert isinstance(out[1], LinkError) and "at most 256 bytes" in str(out[1])
    assert out[2] == b"H"


def test_splitter_reports_an_endless_line_once_and_resynchronises_at_the_next_at():
    splitter = LineSplitter()
    errors = [m for _ in range(10) for m in splitter.feed(b"z" * 100)]
    assert len(errors) == 1 and isinstance(errors[0], LinkError)
    assert splitter.feed(b"zzz@A@") == [b"A"]


@pytest.mark.parametrize("line", ["E1", "E0", "A", "JX", "JY", "JZ", "H", "45334 34623 -54934", "!why"])
def test_reply_forms_of_the_paper(line):
    assert is_reply(line)


def test_not_replies_and_positions():
    assert not is_reply("J") and not is_reply("E2") and not is_reply("1 2")
    assert parse_position("45334 34623 -54934") == (45334, 34623, -54934)
    assert parse_position("H") is None


def test_servo_section_must_agree_with_the_axes_pulses_per_mm(tmp_path):
    text = open(MILL.source).read().replace("encoder_counts_per_rev = 5000", "encoder_counts_per_rev = 4000")
    path = tmp_path / "mill.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"\[servo\] encoder_counts_per_rev = 4000: .* 800 pulses/mm"):
        load_machine(path)


def test_servo_section_rejects_a_typo(tmp_path):
    text = open(MILL.source).read().replace("kp = 0.5", "kpp = 0.5")
    path = tmp_path / "mill.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=r"\[servo\] kpp: unknown key \(did you mean kp\?\)"):
        load_machine(path)


def test_rows_of_a_square_start_and_end_at_rest_within_speed_and_acceleration():
    square = [(20, 20, -5), (30, 20, -5), (30, 30, -5), (20, 30, -5), (20, 20, -5)]
    rows = list(plan_rows(MILL, square[0], [(p, 1200.0) for p in square[1:]]))
    pos = np.array([r.positions for r in rows], dtype=float)
    feeds = np.array([r.feeds for r in rows])
    assert rows[0] == Row((0, 0, 0), (20000, 20000, -5000))
    assert rows[-1] == Row((0, 0, 0), (20000, 20000, -5000))
    speed = np.diff(pos, axis=0).max() / MILL.tick_s / 1000.0             # mm/s, per axis
    assert speed == pytest.approx(20.0, abs=0.6)                            # F1200 = 20 mm/s
    assert abs(feeds).max() == round(20.0 * 255 / 50.0)                     # 255 = 50 mm/s
    path_speed = np.hypot(feeds[:, 0], feeds[:, 1]) * 50.0 / 255             # mm/s, along the path
    feed_rounding = math.sqrt(2) * 50.0 / 255
    assert np.abs(np.diff(path_speed)).max() <= 500.0 * MILL.tick_s + feed_rounding   # 500 mm/s^2
    corners = [i for i, p in enumerate(pos) if tuple(p[:2]) in {(30000.0, 20000.0), (30000.0, 30000.0)}]
    assert corners, "the path passes through the square's corners"


def test_arc_points_keep_the_chord_error_within_tolerance():
    pts = arc_points((100, 100, -5), 20.0, 0.0, 90.0, tolerance_mm=0.002)
    mids = [((a[0] + b[0]) / 2, (a[1] + b[1]) / 2) for a, b in zip(pts, pts[1:])]
    sag = max(20.0 - math.hypot(x - 100, y - 100) for x, y in mids)
    assert 0.0 < sag <= 0.002
    assert pts[-1][:2] == pytest.approx((100.0, 120.0))


def test_a_path_job_follows_the_papers_sequence():
    job = list(path_job(MILL, [((10, 0, 0), 600.0)], coolant=True, spindle=150, tool=(1, 34)))
    heads = [m for m in job if not isinstance(m, Row)]
    assert heads == [Auto(), Machining(True), Home(), ToolChange(1, 34), Operation(True), Spindle(150),
                     EndOperation(), Machining(False)]
    assert job[-3].positions == (10000, 0, 0)


def test_a_gcode_program_becomes_operations_split_at_coolant_changes():
    from retrofit.gcode import compile_program
    prog = compile_program("G0 X10 Y10 Z-5\nM3 S1500\nM8\nG1 X20 F600\nM9\nM5\nG28\nM2", MILL)
    heads = [str(m) for m in program_job(MILL, prog.commands) if not isinstance(m, Row)]
    assert heads == ["A", "M1", "H", "P0", "S128", "#", "P1", "#", "S0", "H", "M0"]


def test_a_counter_clockwise_spindle_is_refused():
    from retrofit.gcode import compile_program
    prog = compile_program("M4 S1000\nG0 X5", MILL)
    with pytest.raises(LinkError, match="clockwise only"):
        list(program_job(MILL, prog.commands))
