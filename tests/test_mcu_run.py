"""``retrofit mcu`` as a separate process, and ``retrofit run`` sending a program to it (serial://)."""

import json
import re
import subprocess
import sys
import time

import numpy as np
import pytest

from retrofit.cli import main
from retrofit.errors import LinkError, OutputError
from retrofit.frames import PortFrames
from retrofit.machine.config import load_machine
from retrofit.outputs import open_output

from tests.conformance.targets import McuTarget, die_with_parent

MACHINE = "mitic-lathe"


def run(tmp_path, program: str, output: str, name: str) -> dict:
    """``retrofit run`` with a JSON report; the report."""
    report = tmp_path / f"{name}.json"
    assert main(["run", program, "--machine", MACHINE, "--output", output, "--progress", "off",
                 "--report", str(report)]) == 0
    return json.loads(report.read_text())


def end_steps(report: dict) -> dict[str, int]:
    """Where a sim:// run's controller ended: its last commanded position, in steps."""
    machine = load_machine(MACHINE)
    return {name: machine.axis(name).to_steps(ax["target_mm"]) for name, ax in report["axes"].items()}


def test_the_lathe_example_over_tcp_ends_where_it_ends_on_sim(tmp_path, capsys):
    local = run(tmp_path, "lathe-profile.ngc", "sim://", "local")
    with McuTarget() as mcu:
        remote = run(tmp_path, "lathe-profile.ngc", mcu.output_url, "remote")
    part = remote["remote"][0]
    assert part["position_steps"] == end_steps(local)
    assert part["status"] == ["SPINDLE_ON"] or "SPINDLE_ON" not in part["status"]
    assert part["link"]["frames_sent"] >= part["commands"] + 2          # SYNC on both channels
    assert set(remote) - set(local) == {"remote"}                       # the same report, plus
    assert remote["axes"] == local["axes"]
    out = capsys.readouterr().out
    assert re.search(r"remote serial\+socket://127\.0\.0\.1:\d+: RDPS X 30\.000, Z 10\.000 mm", out)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs a Linux pty")
def test_a_short_program_over_a_pty(tmp_path):
    program = tmp_path / "short.ngc"
    program.write_text("G21 G18 G90\nG0 X5 Z2\nG1 X4 Z-3 F200\nG2 X6 Z-5 R2\nG0 X8 Z1\nM30\n")
    local = run(tmp_path, str(program), "sim://", "local")
    proc = subprocess.Popen([sys.executable, "-m", "retrofit.cli", "mcu", "--machine", MACHINE,
                             "--pty"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=die_with_parent)
    try:
        line = proc.stdout.readline()
        pty = re.search(r"on (/dev/pts/\d+)", line)
        assert pty, line
        remote = run(tmp_path, str(program), f"serial://{pty.group(1)}?baud=115200", "remote")
    finally:
        proc.kill()
        proc.wait(10)
        proc.stdout.close()
        proc.stderr.close()
    assert remote["remote"][0]["position_steps"] == end_steps(local) == {"X": 800, "Z": 80}


def test_serial_takes_commands_not_frames_and_names_what_is_wrong():
    machine = load_machine(MACHINE)
    out = open_output("serial+socket://127.0.0.1:9", machine)
    with pytest.raises(OutputError, match=r"takes commands, not port frames; use send_program"):
        out.write(PortFrames(np.array([0], dtype=np.int64), np.array([0], dtype=np.uint8), 1))
    with pytest.raises(OutputError, match=r"unknown option 'speed'; expected serial:///dev/ttyUSB0"):
        open_output("serial:///dev/ttyUSB0?speed=9600", machine)
    with pytest.raises(OutputError, match=r"serial\+socket://127\.0\.0\.1:9: serial link "
                                          r"'socket://127\.0\.0\.1:9': cannot open it"):
        open_output("serial+socket://127.0.0.1:9", machine).open()


def test_demo_refuses_a_command_level_output(capsys):
    assert main(["demo", "circle", "--points", "4", "--output", "serial+socket://127.0.0.1:9"]) == 2
    assert "runs a program's commands" in capsys.readouterr().err


def test_retrofit_outputs_lists_the_serial_schemes(capsys):
    assert main(["outputs"]) == 0
    out = capsys.readouterr().out
    assert "serial:///dev/ttyUSB0?baud=115200 or serial+socket://HOST:PORT" in out
    assert "serial+socket://HOST:PORT" in out


def test_mcu_needs_a_pty_or_an_address(capsys):
    with pytest.raises(SystemExit):
        main(["mcu", "--machine", MACHINE])
    assert "one of the arguments --pty --listen is required" in capsys.readouterr().err


def test_a_refused_command_fails_the_run_naming_it():
    from retrofit.commands import parse_command
    machine = load_machine(MACHINE)
    with McuTarget() as mcu:
        # sent once, however slow the host: no resend before 30 s without an answer
        with open_output(f"{mcu.output_url}?timeout_ms=30000", machine) as out:
            with pytest.raises(OutputError, match=r"FMOV X45 \(sequence \d+, sent 1 times\): the "
                                                  r"device refused it: refused by the controller"):
                out.send_program([parse_command("FMOV X1"), parse_command("FMOV X45")])
            assert out.remote is None


def test_with_a_simulated_machine_homing_and_a_thread_run(tmp_path):
    from retrofit.link import Ack
    from retrofit.link import StatusFlags as F

    from tests.conformance.rawlink import RawLink
    with McuTarget(MACHINE, "--sim") as mcu:
        link = RawLink(mcu.url, load_machine(MACHINE))
        try:
            link.sync_both()
            for text in ("ZMOV", "FMOV X10 Z5", "SPIN S600 D1", "ISTP", "PFDR F0.5",
                         "PMOV X10 Z-10", "CSTP", "FMOV X20"):
                assert link.send_until_accepted(text) == Ack()
            st = link.wait_idle()
            assert st.flags & F.HOMED and st.flags & F.INDEX_SEEN and not st.flags & F.ERROR
            assert link.position() == {"X": 2000, "Z": -800}
        finally:
            link.close()


@pytest.mark.parametrize("target", ["mcu", "firmware"])
def test_a_position_the_link_cannot_carry_is_err_3_and_the_device_keeps_serving(target):
    """PSTN X8388607 (the top of the 24-bit space), ZMOV, RDPS: the homing move runs X past what
    a POS answer can carry. The device answers ERR 3 and goes on; it must never exit."""
    from retrofit.link import IMMEDIATE, QUEUED, Ack, Err, Status

    from tests.conformance.rawlink import RawLink
    from tests.conformance.targets import SimavrTarget, missing_tools
    if target == "firmware" and missing_tools():
        pytest.skip(f"needs {', '.join(missing_tools())}")
    device = McuTarget(MACHINE) if target == "mcu" else SimavrTarget(MACHINE)
    with device as mcu:
        link = RawLink(mcu.url, load_machine(MACHINE))
        try:
            link.sync_both()
            assert link.send("INIT") == Ack()
            assert link.exchange(QUEUED, 2, bytes.fromhex("0C 01 7FFFFF")) == (0x02, Ack())  # PSTN
            assert link.exchange(QUEUED, 3, bytes.fromhex("03 00")) == (0x03, Ack())         # ZMOV
            answers = []
            for n in range(1, 121):            # RDPS until the move has run past (at most 12 s; numbers < 128)
                answers.append(link.exchange(IMMEDIATE, n, b"\x0d"))
                if answers[-1][1] == Err(3, 0x0D):
                    break
                time.sleep(0.1)
            assert answers[-1] == (0x80 + n, Err(3, 0x0D))
            seq, status = link.exchange(IMMEDIATE, n + 1, b"\x0e")                           # RDST
            assert seq == 0x80 + n + 1 and isinstance(status, Status)
            assert mcu.proc.poll() is None
        finally:
            link.close()


def test_prob_is_refused_err_6_and_error_until_init_the_controller_has_no_probe_input():
    """retrofit mcu's controller reads no probe input: PROB is answered ERR 6 (detail 0x11, its
    opcode) and RDST shows ERROR until INIT; a flags byte with another bit than bit 0 is ERR 3;
    probe_over_link names the refused command."""
    from retrofit.commands import parse_command
    from retrofit.link import QUEUED, Ack, Err, HostLink, probe_over_link
    from retrofit.link import StatusFlags as F

    from tests.conformance.rawlink import RawLink
    machine = load_machine(MACHINE)
    with McuTarget() as mcu:
        link = RawLink(mcu.url, machine)
        try:
            link.sync_both()
            assert link.send("PROB Z-4") == Err(6, 0x11)
            assert link.status().flags & F.ERROR
            assert link.send("INIT") == Ack()
            assert not link.status().flags & F.ERROR
            number = link.next[QUEUED]
            assert link.exchange(QUEUED, number, bytes.fromhex("11 02 04 FF FE C0")) == (number, Err(3, 0x11))
            link.next[QUEUED] = number + 1
            assert not link.status().flags & F.ERROR          # a layout error changes nothing
        finally:
            link.close()
        with HostLink.open(mcu.url, machine, timeout_s=30.0) as host:      # sent once, however slow the host
            with pytest.raises(LinkError, match=r"PROB AWAY X1 \(sequence \d+, sent 1 times\): the "
                                                r"device refused it: refused by the controller"):
                probe_over_link(host, parse_command("PROB AWAY X1"))
