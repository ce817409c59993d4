"""The link attacked: a second host, replayed bytes, a lying device, a host that falls silent.

Each test plays the attacker (or the accident) against ``retrofit mcu`` and the firmware in
simavr and checks what a user would notice: where the machine is (RDPS, the steps on the pins),
whether anything stepped, the exit code and message of ``retrofit run``.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import serial

from retrofit.cli import main
from retrofit.commands import parse_command
from retrofit.firmware.mcu import McuLoop, PtyPort, TcpServerPort, make_controller
from retrofit.link import IMMEDIATE, QUEUED, Ack, DeviceLink, Err, Position, Session, Status, StatusFlags
from retrofit.link.script import SIMAVR_FIRST_SESSION, ScriptedHost
from retrofit.machine.config import load_machine
from retrofit.outputs import open_output

from tests.conformance.rawlink import RawLink
from tests.conformance.targets import McuTarget

MACHINE = "mitic-lathe"                  # X 100, Z 80 steps/mm
F = StatusFlags
S = 16_000_000                           # AVR cycles a second
linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs a Linux pty")
avr = pytest.mark.skipif(shutil.which("avr-gcc") is None or shutil.which("make") is None,
                         reason="the firmware needs avr-gcc and make")


@pytest.fixture(scope="module")
def lathe():
    fs = pytest.importorskip("retrofit.firmware.sim")
    machine = load_machine(MACHINE)
    return machine, fs.build(machine.name)


class DeviceThread:
    """A device served from this process on a pty (``name``), until closed."""

    def __init__(self, make_link):
        self.port = PtyPort()
        self.name = self.port.name
        self.link = make_link(self.port)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        serve = getattr(self.link, "serve_forever", None)
        if serve is not None:
            serve(self.stop.is_set)
        else:
            self.link.serve(self.stop)

    def close(self):
        self.stop.set()
        self.thread.join(10)
        self.port.close()


# -- a second host --------------------------------------------------------------------------------

class HeldLoop(McuLoop):
    """``retrofit mcu``'s loop whose controller stops ticking once X has made ``at_steps`` steps,
    until ``go`` is set; the port is served all the while (the host hears the move go on). A
    moment mid-move that lasts as long as the test needs, on any machine at any load."""

    def __init__(self, *args, at_steps: int, **kwargs):
        super().__init__(*args, **kwargs)
        self.at_steps, self.go = at_steps, threading.Event()

    def _budget(self) -> int:
        if self.go.is_set():
            return super()._budget()
        if self.controller.position_steps[0] >= self.at_steps:
            return 0
        return min(10, super()._budget())          # a few ticks at a time up to the moment


@linux
def test_a_second_host_on_a_running_tty_is_refused_and_the_first_run_ends_where_it_should(tmp_path):
    machine = load_machine(MACHINE)
    ctl = make_controller(machine)
    device = DeviceThread(lambda port: HeldLoop(port, machine, ctl, at_steps=100))
    issued = device.link.link.endpoint.sessions
    program = tmp_path / "second.ngc"
    program.write_text("G21 G18 G90\nG0 X3 Z-2\nM30\n")
    try:
        first = open_output(f"serial://{device.name}", machine)
        first.open()
        start = issued.next
        result = {}
        commands = [parse_command(t) for t in ("PFDR F300", "PMOV X30 Z-3")]   # 6 s at 5 mm/s
        runner = threading.Thread(target=lambda: result.update(first.send_program(commands)))
        runner.start()
        deadline = time.monotonic() + 60
        while ctl.position_steps[0] < 100 and time.monotonic() < deadline:
            time.sleep(0.01)                                  # the first host's move is under way
        second = subprocess.run([sys.executable, "-m", "retrofit.cli", "run", str(program),
                                 "--machine", MACHINE, "--output", f"serial://{device.name}",
                                 "--progress", "off"], capture_output=True, text=True, timeout=120)
        moving_when_refused = runner.is_alive() and ctl.position_steps[0] < 3000
        device.link.go.set()                                  # the first move goes on to its end
        runner.join(120)
        host_sessions = first.link.endpoint.stats.sessions
        first.close()
    finally:
        device.close()
    assert second.returncode == 2, second.stdout + second.stderr
    assert "another host holds the port" in second.stderr
    assert moving_when_refused                                 # refused mid-move
    assert issued.next - start == host_sessions                # every session was the first host's
    assert result["position_steps"] == {"X": 3000, "Z": -240}  # the first run's own end
    assert not set(result["status"]) & {"STOPPED", "ERROR", "HOST_LOST"}


def test_a_second_host_on_a_served_tcp_port_gets_no_answer_and_the_first_goes_on(tmp_path, capsys):
    """Over TCP there is no lock: retrofit mcu serves one connection at a time, so the second
    host hears nothing and gives up (exit 2) while the first host's move ends where it should."""
    machine = load_machine(MACHINE)
    program = tmp_path / "second.ngc"
    program.write_text("G21 G18 G90\nG0 X3 Z-2\nM30\n")
    with McuTarget() as mcu:
        first = RawLink(mcu.url, machine)
        first.sync_both()
        assert first.send("INIT") == Ack() and first.send("FMOV X20 Z-3") == Ack()
        done = threading.Event()
        polls = []

        def keep_polling():                       # the first host keeps its link alive
            while not done.is_set():
                polls.append(first.status())
                time.sleep(0.05)
        poller = threading.Thread(target=keep_polling)
        poller.start()
        try:
            code = main(["run", str(program), "--machine", MACHINE, "--output",
                         f"{mcu.output_url}?boot_ms=500", "--progress", "off"])
        finally:
            done.set()
            poller.join(10)
        st = first.wait_idle()
        where = first.position()
        first.close()
    assert code == 2 and "no banner and no answer to SYNC" in capsys.readouterr().err
    assert where == {"X": 2000, "Z": -240} and not st.flags & (F.STOPPED | F.ERROR | F.HOST_LOST)


def test_a_serial_run_that_fails_sends_stop_before_it_closes():
    """safe_stop() (what a failing or interrupted run calls first) stops the far end at once,
    without waiting for the heartbeat."""
    machine = load_machine(MACHINE)
    with McuTarget() as mcu:
        out = open_output(mcu.output_url, machine)
        out.open()
        for text in ("INIT", "PFDR F60", "PMOV X30"):             # 30 s of machine time
            out.link.request(parse_command(text))
        out.safe_stop()
        out.close()
        after = RawLink(mcu.url, machine)
        after.sync_both()
        st = after.wait_idle()
        where = after.position()
        after.close()
    assert st.flags & F.STOPPED and not st.flags & F.HOST_LOST     # STOP, not the heartbeat
    assert where["X"] < 3000


# -- replayed bytes ---------------------------------------------------------------------------------

class Recording(RawLink):
    """A RawLink that keeps every byte it writes: what a tap on the line would record."""

    def __init__(self, *args, **kwargs):
        self.recorded = bytearray()
        super().__init__(*args, **kwargs)

    def write(self, data: bytes) -> None:
        self.recorded += data
        super().write(data)


def sessions_in(machine, answers: bytes) -> int:
    """How many SESS answers (to a SYNC) ``answers`` holds."""
    return sum(isinstance(r, Session) for r in ScriptedHost(machine).replies(answers, keepalives=True))


def test_bytes_of_an_earlier_session_replayed_to_retrofit_mcu_run_nothing():
    machine = load_machine(MACHINE)
    with McuTarget() as mcu:
        first = Recording(mcu.url, machine)
        first.sync_both()
        for text in ("INIT", "PFDR F1200", "PMOV X10"):
            assert first.send_until_accepted(text) == Ack()
        first.wait_idle()
        assert first.position() == {"X": 1000, "Z": 0}
        first.close()
        other = RawLink(mcu.url, machine)                    # another session moves elsewhere
        other.sync_both()
        assert other.send_until_accepted("PMOV X5") == Ack()
        other.wait_idle()
        assert other.position() == {"X": 500, "Z": 0}
        other.close()
        replay = serial.serial_for_url(mcu.url, timeout=0.05)
        replay.write(bytes(first.recorded))                  # every byte, SYNCs included
        answers = b""
        end = time.monotonic() + 60                          # a ceiling: the replayed SYNCs answered
        while sessions_in(machine, answers) < 2 and time.monotonic() < end:
            answers += replay.read(4096)
        end = time.monotonic() + 2.0                         # and any answer after them
        while time.monotonic() < end:
            answers += replay.read(4096)
        replay.close()
        after = RawLink(mcu.url, machine)
        after.sync_both()
        st = after.wait_idle()
        assert after.position() == {"X": 500, "Z": 0}        # neither INIT nor PMOV X10 ran
        assert not st.flags & (F.MOVING | F.ERROR)
        after.close()
    got = ScriptedHost(machine).replies(answers, keepalives=True)
    assert got and not any(isinstance(r, (Ack, Position, Status)) for r in got), got


@avr
def test_bytes_of_an_earlier_session_replayed_to_the_firmware_step_nothing(lathe):
    """In simavr, one byte stream: a session that moves (INIT, PMOV X10), another that moves to
    X5, the first session's bytes again as recorded, then a host that reads RDPS. After the
    replay began not one step comes out on the pins, and RDPS says X5."""
    fs = pytest.importorskip("retrofit.firmware.sim")
    machine, elf = lathe
    ms = S // 1000

    def polled(host, start, texts, polls):
        items = [(start + k * ms, host.frame(t)) for k, t in enumerate(texts)]
        return items + [(start + (10 + 10 * k) * ms, host.frame("RDST")) for k in range(polls)]

    first = ScriptedHost(machine)
    recorded = [(1_000_000, first.sync(QUEUED)), (1_000_000, first.sync(IMMEDIATE))]
    recorded += polled(first, 1_100_000, ["INIT", "PFDR F1200", "PMOV X10"], 70)
    other = ScriptedHost(machine, first_session=SIMAVR_FIRST_SESSION + 2, nonce=0x0BE20000)
    second = [(int(0.9 * S), other.sync(QUEUED)), (int(0.9 * S), other.sync(IMMEDIATE))]
    second += polled(other, int(0.9 * S) + ms, ["PMOV X5"], 50) + [(int(1.5 * S), other.frame("RDPS"))]
    replay_at = int(1.6 * S)
    replayed = [(c - 1_000_000 + replay_at, data) for c, data in recorded]
    reader = ScriptedHost(machine, first_session=SIMAVR_FIRST_SESSION + 6, nonce=0x0C0E0000)
    t = int(2.5 * S)
    third = [(t, reader.sync(QUEUED)), (t, reader.sync(IMMEDIATE)), (t + ms, reader.frame("RDST")),
             (t + 2 * ms, reader.frame("RDPS"))]
    log = fs.Harness(elf, machine, script=recorded + second + replayed + third,
                     cycles=t + 50 * ms).run()
    rises, _, _ = fs.step_times(log, machine, "X")
    assert (rises < int(0.9 * S)).sum() >= 1000                       # the first session moved
    assert ((rises > int(0.9 * S)) & (rises < replay_at)).sum() >= 500  # so did the other
    assert (rises >= replay_at).sum() == 0                             # the replay: not a step
    answers = ScriptedHost(machine).replies(log.answer_bytes())
    assert answers[-1] == Position((("X", 500), ("Z", 0)))
    assert not answers[-2].flags & (F.MOVING | F.ERROR | F.STOPPED)


# -- a lying device ---------------------------------------------------------------------------------

def liar(cmd):
    """A device that takes every command and says: idle, at X0 Z0."""
    name = type(cmd).__name__
    if name == "Rdps":
        return Position((("X", 0), ("Z", 0)))
    if name == "Rdst":
        return Status(F(0), 0)
    return None


@linux
def test_a_device_that_lies_about_where_it_ended_fails_the_run_with_both_positions(tmp_path, capsys):
    machine = load_machine(MACHINE)
    program = tmp_path / "lie.ngc"
    program.write_text("G21 G18 G90\nG0 X10 Z-10\nM30\n")
    device = DeviceThread(lambda port: DeviceLink(port, machine, liar))
    try:
        code = main(["run", str(program), "--machine", MACHINE, "--output",
                     f"serial://{device.name}", "--progress", "off"])
    finally:
        device.close()
    err = capsys.readouterr().err
    assert code == 2
    assert "reports the end position X0 Z0 steps (RDPS)" in err
    assert "the program ends at X1000 Z-800 steps" in err


# -- a host that falls silent -------------------------------------------------------------------------

def x_rises(frames, machine) -> np.ndarray:
    """Ticks of the rising edges of X's step bit in a controller's port frames."""
    bit = machine.axis("X").step_bit
    level = (np.asarray(frames.values) >> bit) & 1
    prev = np.concatenate(([0], level[:-1]))
    return np.asarray(frames.ticks)[(level == 1) & (prev == 0)]


def braking_s(machine, axis="X") -> float:
    """How long the axis takes to stop from the rapid at its acceleration (the machine file)."""
    a = machine.axis(axis)
    v = min(machine.motion.rapid_feed_mm_min / 60.0, a.max_velocity_mm_s)
    return v / a.max_accel_mm_s2


def test_retrofit_mcu_brakes_a_move_whose_host_fell_silent_and_knows_where_it_stopped():
    machine = load_machine(MACHINE)
    ctl = make_controller(machine, backlash_comp=False)
    port = TcpServerPort("127.0.0.1", 0)
    loop = McuLoop(port, machine, ctl)
    stop = threading.Event()
    thread = threading.Thread(target=loop.serve_forever, args=(stop.is_set,), daemon=True)
    thread.start()
    url = f"socket://127.0.0.1:{port.address[1]}"
    try:
        host = RawLink(url, machine)
        host.sync_both()
        assert host.send("INIT") == Ack() and host.send("FMOV X39") == Ack()   # 1.56 s of rapid
        while not host.status().flags & F.MOVING:
            pass
        host.close()                                          # the host is gone: not a byte more
        deadline = time.monotonic() + 60
        while not (ctl.processor.host_lost and ctl.idle) and time.monotonic() < deadline:
            time.sleep(0.05)                                  # (a new host's frames would be heard)
        later = RawLink(url, machine)
        later.sync_both()
        st = later.wait_idle()
        where = later.position()
        refused = later.send("FMOV X1")
        assert later.send("INIT") == Ack()
        cleared = later.status()
        later.close()
    finally:
        stop.set()
        thread.join(10)
        port.close()
    assert st.flags & F.STOPPED and st.flags & F.HOST_LOST and not st.flags & F.MOVING
    assert refused == Err(6, 0x02)                            # motion refused until INIT
    assert not cleared.flags & (F.STOPPED | F.HOST_LOST)
    heard, braked = ctl.host_lost_at
    assert braked - heard == ctl.heartbeat_ticks == machine.ticks(0.5)
    rises = x_rises(ctl.frames(), machine)
    assert where == {"X": len(rises), "Z": 0}                 # RDPS: the steps on the wire
    assert 0 < where["X"] < 3900                               # stopped short of X39
    assert rises[-1] > heard + ctl.heartbeat_ticks            # it moved until the heartbeat
    assert rises[-1] - braked <= machine.ticks(braking_s(machine) + 0.01)
    gaps = np.diff(rises)
    cruise = np.median(gaps)
    assert gaps[-1] > 4 * cruise                               # braked, not cut off at speed


@linux
def test_a_retrofit_run_killed_mid_move_leaves_retrofit_mcu_braked_and_refusing_motion(tmp_path):
    """SIGKILL of the host process: nothing closes the port politely, nothing says STOP. The
    device (on a pty, held at X 3 mm until the host is killed) brakes on its own, RDPS equals the steps on
    the wire, and motion is refused until INIT."""
    import signal
    machine = load_machine(MACHINE)
    ctl = make_controller(machine, backlash_comp=False)
    device = DeviceThread(lambda port: HeldLoop(port, machine, ctl, at_steps=300))
    program = tmp_path / "long.ngc"
    program.write_text("G21 G18 G90\nG1 X30 F600\nM30\n")          # 3 s at 10 mm/s
    try:
        host = subprocess.Popen([sys.executable, "-m", "retrofit.cli", "run", str(program),
                                 "--machine", MACHINE, "--output", f"serial://{device.name}",
                                 "--progress", "off"], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 60
        while ctl.position_steps[0] < 300 and time.monotonic() < deadline:
            time.sleep(0.01)                                  # under way: X past 3 mm
        host.send_signal(signal.SIGKILL)
        host.wait(30)
        device.link.go.set()                                  # the move goes on, its host gone
        deadline = time.monotonic() + 60
        while not (ctl.processor.host_lost and ctl.idle) and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        device.close()
    st = ctl.status
    assert st.flags & F.HOST_LOST and st.flags & F.STOPPED and not st.flags & F.MOVING
    rises = x_rises(ctl.frames(), machine)
    assert ctl.position_steps == (len(rises), 0) and 300 <= len(rises) < 3000
    heard, braked = ctl.host_lost_at
    assert braked - heard == machine.ticks(0.5)
    assert rises[-1] - braked <= machine.ticks(braking_s(machine) + 0.01)
    assert ctl.submit(parse_command("FMOV X1")) == Err(6, 0x02)


@avr
def test_the_firmware_brakes_a_move_whose_host_fell_silent_and_knows_where_it_stopped(lathe):
    """In simavr: FMOV X39 at the rapid, then nothing from the host. Within the heartbeat's
    500 ms, the segments already cut (60 ms) and the braking at X's acceleration the last step
    comes; the steps slow down before it; a new host finds STOPPED and HOST_LOST, RDPS equal to
    the steps on the pins, motion refused until INIT."""
    fs = pytest.importorskip("retrofit.firmware.sim")
    machine, elf = lathe
    ms = S // 1000
    host = ScriptedHost(machine)
    last = 3_200_000
    items = [(1_000_000, host.sync(QUEUED)), (1_000_000, host.sync(IMMEDIATE)),
             (last, host.frame("FMOV X39"))]                  # and then silence
    later = ScriptedHost(machine, first_session=SIMAVR_FIRST_SESSION + 2, nonce=0x1A7E0000)
    t = int(2.0 * S)
    items += [(t, later.sync(QUEUED)), (t, later.sync(IMMEDIATE))]
    items += [(t + k * ms, later.frame(text))
              for k, text in enumerate(("RDST", "RDPS", "FMOV X1", "INIT", "RDST"), 1)]
    log = fs.Harness(elf, machine, script=items, cycles=t + 50 * ms).run()
    rises, _, _ = fs.step_times(log, machine, "X")
    rdst, rdps, refused, init, cleared = ScriptedHost(machine).replies(log.answer_bytes())[-5:]
    x = machine.axis("X")
    assert rdps == Position((("X", len(rises) - x.backlash_steps), ("Z", 0)))   # the pins' steps
    assert 0 < rdps.steps[0][1] < 3900
    assert rdst.flags & F.STOPPED and rdst.flags & F.HOST_LOST and not rdst.flags & F.MOVING
    assert refused == Err(6, 0x02) and init == Ack()
    assert not cleared.flags & (F.STOPPED | F.HOST_LOST)
    frame_end = last + 200 * 16                               # the FMOV frame's bytes at 57 600 baud
    assert rises[-1] - frame_end > int(0.45 * S)               # it moved until the heartbeat
    assert rises[-1] - frame_end < int((0.5 + 0.06 + braking_s(machine) + 0.025) * S)
    gaps = np.diff(rises)
    assert gaps[-1] > 4 * np.median(gaps)                      # braked, not cut off at speed
