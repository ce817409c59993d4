"""The paced loop: bytes on the (recorded) port equal the frames, every tick, in order; lateness figures.

The tests that pace a run do it with both engines (the compiled writer and the Python loop).
"""

import os
import re
from pathlib import Path

import numpy as np
import pytest

from retrofit.demo import circle_targets
from retrofit.errors import OutputError
from retrofit.frames import PortFrames
from retrofit.machine.config import load_machine
from retrofit.motion.errorloop import PositionErrorLoop
from retrofit.outputs import open_output, pacer_build
from retrofit.outputs.pacer import Lateness, Pacer, RealtimeMode, calibrate, repeat_frames
from retrofit.outputs.record import load_recording
from retrofit.run.runner import deliver


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


@pytest.fixture(params=["compiled", "python"])
def engine(request):
    return request.param


@pytest.fixture(scope="module")
def short_log(lathe):
    """A small circle (r = 2 mm, 20 points): about 2,500 ticks, 0.5 s when paced at 200 us."""
    return PositionErrorLoop(lathe).run(circle_targets(lathe, 2.0, 20))


def record(lathe, frames, path, query):
    out = open_output(f"parport+record://{path}?{query}", lathe)
    out.quiet = True
    with out:
        out.write(frames)
    return out


def test_paced_bytes_equal_the_sim_frames_every_tick_in_order(lathe, short_log, tmp_path, engine):
    """Through the runner, next to sim://: the recording is the frames the simulator saw, bit for bit."""
    path = tmp_path / "run.bin"
    url = f"parport+record://{path}?tick_us=200&every_tick=1&force=1&engine={engine}"
    sim = deliver(short_log, ["sim://", url])
    assert sim.end_tick == short_log.frames.end_tick
    data = np.fromfile(path, np.uint8)
    assert len(data) == short_log.frames.end_tick, "one byte per tick, none skipped"
    assert np.array_equal(data, short_log.frames.per_tick())
    assert load_recording(path) == short_log.frames


def test_every_tick_mode_writes_each_tick_itself(lathe, short_log, tmp_path, engine):
    out = record(lathe, short_log.frames, tmp_path / "r.bin", f"tick_us=200&every_tick=1&force=1&engine={engine}")
    assert out.pacer.engine == engine
    rec = out.recording
    assert rec.writes == short_log.frames.end_tick
    assert rec.filled == 0, "the loop wrote every tick; the recorder held nothing over"
    assert out.timing.writes == rec.writes and out.timing.paced
    assert out.timing.p50_ns <= out.timing.p99_ns <= out.timing.max_ns


def test_changes_mode_writes_only_changes_and_the_latch_holds_them(lathe, short_log, tmp_path, engine):
    out = record(lathe, short_log.frames, tmp_path / "r.bin", f"tick_us=200&force=1&engine={engine}")
    assert out.recording.writes == len(short_log.frames)
    assert load_recording(tmp_path / "r.bin") == short_log.frames


def test_unpaced_full_circle_same_code_path(lathe, tmp_path, engine):
    log = PositionErrorLoop(lathe).run(circle_targets(lathe))
    out = record(lathe, log.frames, tmp_path / "c.bin", f"paced=0&every_tick=1&engine={engine}")
    assert not out.timing.paced and out.calibration is None
    assert np.array_equal(np.fromfile(tmp_path / "c.bin", np.uint8), log.frames.per_tick())


def test_chunks_continue_one_schedule(lathe, short_log, tmp_path, engine):
    frames = short_log.frames
    cut = int(frames.ticks[len(frames) // 2]) + 1
    first = frames.ticks < cut
    chunks = [PortFrames(frames.ticks[first], frames.values[first], cut),
              PortFrames(frames.ticks[~first], frames.values[~first], frames.end_tick)]
    out = open_output(f"parport+record://{tmp_path / 'k.bin'}?tick_us=50&force=1&every_tick=1&engine={engine}", lathe)
    out.quiet = True
    with out:
        for chunk in chunks:
            out.write(chunk)
    assert load_recording(tmp_path / "k.bin") == frames
    with pytest.raises(OutputError, match="tick order"):
        with open_output(f"parport+record://{tmp_path / 'bad.bin'}?paced=0", lathe) as out:
            out.write(chunks[1])
            out.write(chunks[0])


def test_pacer_writes_at_tick_boundaries_in_order(engine):
    seen = []
    pacer = Pacer(100_000, every_tick=True, spin_ns=50_000, engine=engine)
    pacer.play(PortFrames.from_per_tick([0, 1, 1, 3, 3, 0]), lambda tick, value: seen.append((tick, value)))
    timing = pacer.finish()
    assert seen == [(0, 0), (1, 1), (2, 1), (3, 3), (4, 3), (5, 0)]
    assert timing.writes == 6 and len(timing.samples_ns) == 6
    assert (timing.samples_ns >= 0).all(), "no write before its tick boundary"


#: a tick neither loop can hold (10 ns): shorter than one clock read, so every write falls further behind
IMPOSSIBLE_TICK_US = {"compiled": 0.01, "python": 0.01}


def test_late_writes_are_written_not_skipped(lathe, short_log, tmp_path, engine):
    """A tick that cannot be held; forced, every byte still goes out in order."""
    tick = IMPOSSIBLE_TICK_US[engine]
    out = record(lathe, short_log.frames, tmp_path / "f.bin", f"tick_us={tick}&every_tick=1&force=1&engine={engine}")
    assert not out.calibration.holds
    assert out.timing.late > 0
    assert load_recording(tmp_path / "f.bin") == short_log.frames


def test_a_tick_this_computer_cannot_hold_is_refused_with_the_figure(lathe, tmp_path, engine):
    tick = IMPOSSIBLE_TICK_US[engine]
    with pytest.raises(OutputError) as err:
        open_output(f"parport+record://{tmp_path / 'x.bin'}?tick_us={tick}&engine={engine}", lathe).open()
    text = str(err.value)
    said = "10 ns"
    assert f"cannot hold a {said} tick" in text and "force=1" in text
    assert re.search(r"p99 lateness [\d.]+ (us|ns)", text) and "\n" not in text
    assert not (tmp_path / "x.bin").exists()


def test_calibration_reports_a_shortest_tick():
    cal = calibrate(200_000)
    assert cal.trial.writes >= 200
    assert cal.shortest_tick_ns == 2 * cal.trial.p99_ns
    assert "calibration:" in cal.line()


def test_lateness_figures():
    tick = 50_000
    samples = [1_000] * 98 + [30_000, 90_000]
    lat = Lateness.of(tick, 100, samples)
    assert (lat.p50_ns, lat.max_ns, lat.late) == (1_000, 90_000, 2)
    assert 30_000 <= lat.p99_ns <= 90_000
    assert "p50 1.0 us" in lat.line() and "2 later than half a tick (25.0 us)" in lat.line()


def test_realtime_mode_says_what_it_got_and_gives_it_back():
    before = os.sched_getscheduler(0)
    mode = RealtimeMode()
    notes = mode.enter()
    try:
        assert len(notes) == 2
        assert notes[0].startswith(("SCHED_FIFO priority", "SCHED_FIFO not permitted"))
        assert notes[1].startswith(("memory locked", "mlockall not"))
    finally:
        mode.leave()
    assert os.sched_getscheduler(0) == before


def test_realtime_mode_says_plainly_what_was_not_permitted(monkeypatch):
    import ctypes
    import errno

    def refuse(*args):
        raise PermissionError(errno.EPERM, "Operation not permitted")

    class NoLock:
        def mlockall(self, flags):
            return -1

    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    monkeypatch.setattr(ctypes, "CDLL", lambda *a, **k: NoLock())
    monkeypatch.setattr(ctypes, "get_errno", lambda: errno.EPERM)
    mode = RealtimeMode()
    fifo, lock = mode.enter()
    mode.leave()
    assert fifo.startswith("SCHED_FIFO not permitted (Operation not permitted): the loop runs at normal priority")
    assert "rtprio" in fifo and "memlock" in lock
    assert lock.startswith("mlockall not permitted")
    assert not mode.fifo


def test_repeat_frames_tiles_the_run():
    base = PortFrames.from_per_tick([0, 1, 1, 0])
    assert np.array_equal(repeat_frames(base, 10).per_tick(), [0, 1, 1, 0, 0, 1, 1, 0, 0, 1])


def test_only_the_pacer_reads_the_clock_or_sleeps():
    """Of the port outputs only pacer.py reads the clock; of the C files only pacer_c.c, which it drives.

    The C file must read it too: it is the same paced loop, moved out of the interpreter so the
    GIL is released while it waits and writes.
    """
    package = Path(__file__).resolve().parents[1] / "retrofit"
    for name in ("parport.py", "record.py", "vcd.py", "pacer_build.py"):
        text = (package / "outputs" / name).read_text()
        assert not re.search(r"^\s*(import time|from time import)", text, re.M), name
        assert "sleep(" not in text and "perf_counter" not in text, name
    readers = [p.name for p in package.rglob("*.[ch]") if re.search(r"clock_gettime|nanosleep", p.read_text())]
    assert readers == ["pacer_c.c"]


def test_without_a_compiler_the_python_loop_paces_and_says_why(lathe, short_log, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))     # nothing built yet
    monkeypatch.setenv("CC", "no-such-cc")
    out = record(lathe, short_log.frames, tmp_path / "n.bin", "tick_us=200&every_tick=1&force=1")
    assert out.pacer.engine == "python"
    assert load_recording(tmp_path / "n.bin") == short_log.frames
    note = [line for line in out.report_lines() if line.startswith("engine:")]
    assert note == ["engine: Python loop (the compiled writer is not available: no C compiler: "
                    "'no-such-cc' not found on PATH (install gcc, or set CC))"]
    with pytest.raises(OutputError, match="engine=compiled: the compiled writer is not available: no C compiler"):
        Pacer(200_000, engine="compiled")
    assert not (tmp_path / "cache" / "retrofit").exists() or not list((tmp_path / "cache" / "retrofit").iterdir())


def test_a_source_that_does_not_compile_is_refused_with_the_compiler_message(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    bad = tmp_path / "pacer_c.c"
    bad.write_text("int retrofit_now_ns(void) { return }\n")
    with pytest.raises(pacer_build.BuildError, match=r"gcc failed to build pacer_c.c \(exit 1\): .*error"):
        pacer_build.build(bad)
    assert list((tmp_path / "cache" / "retrofit").iterdir()) == [], "no half-built library left behind"


def test_the_library_is_cached_and_rebuilt_when_the_source_changes(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    source = tmp_path / "pacer_c.c"
    source.write_text(pacer_build.SOURCE.read_text())
    first = pacer_build.build(source)
    built = first.stat().st_mtime_ns
    assert pacer_build.build(source) == first and first.stat().st_mtime_ns == built, "not rebuilt"
    source.write_text(source.read_text() + "\n/* changed */\n")
    second = pacer_build.build(source)
    assert second != first and second.exists()
    assert second.parent == tmp_path / "cache" / "retrofit"


def test_unknown_engine_is_refused_with_the_choices(lathe, tmp_path):
    with pytest.raises(OutputError, match=r"engine='fast': expected one of auto, compiled, python"):
        open_output(f"parport+record://{tmp_path / 'e.bin'}?engine=fast", lathe)


def test_the_compiled_writer_writes_to_the_port_fd_with_ppdev_and_says_when_refused(tmp_path):
    """Given a file descriptor, the C loop writes with ioctl PPWDATA; a file that is no port refuses it."""
    with open(tmp_path / "not-a-port", "wb") as f:
        pacer = Pacer(200_000, paced=False, engine="compiled")
        with pytest.raises(OutputError, match=r"port write 1 of the chunk \(tick 3\) failed: Inappropriate ioctl"):
            pacer.play(PortFrames(np.array([3]), np.array([5], np.uint8), 5),
                       lambda tick, value: pytest.fail("write() is not called when the port has a fd"), f.fileno())
