"""A console that ends mid-run leaves its outputs safe: SIGHUP (the terminal closed) and SIGTERM put
every data pin of the port at rest (step lines low) and the drivers' enable off, then close; an
exception in the run does the same first, and STOP still answers. SIGKILL leaves nothing to run:
what the recording shows then is stated here as it is."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from console_kit import LONG_MOVE, Served, free_port

from retrofit.console.server import Console
from retrofit.frames import PinMap
from retrofit.machine.config import load_machine

ENABLE_LOW = '\n[parport]\nenable_pin = 14\nenable_level = "low"\n'


def step_mask(machine) -> int:
    return sum(1 << a.step_bit for a in machine.axes)


class ConsoleProcess:
    """``retrofit console`` in a process of its own, driven over its API as the page drives it."""

    def __init__(self, *args: str, listen: str = "127.0.0.1"):
        self.port = free_port()
        self.proc = subprocess.Popen([sys.executable, "-m", "retrofit.cli", "console", "--listen",
                                      f"{listen}:{self.port}", *args],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        found = re.search(r"http://127\.0\.0\.1:(\d+)/\?token=([A-Za-z0-9_-]+)", line)
        assert found, (line, self.proc.stderr.read() if self.proc.poll() is not None else "")
        self.client = Served.__new__(Served)
        self.client.port, self.client.token, self.client.control = self.port, found[2], None
        for _ in range(1200):                  # up to a minute for the server to answer
            try:
                self.client.state()
                break
            except (OSError, AssertionError):
                time.sleep(0.05)

    def end(self, sig: int) -> int:
        self.proc.send_signal(sig)
        return self.proc.wait(60)


@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGTERM, signal.SIGINT], ids=["SIGHUP", "SIGTERM", "SIGINT"])
def test_a_signal_mid_run_leaves_the_port_at_rest(tmp_path, sig):
    machine = load_machine("chivu-lathe")
    record = tmp_path / "port.bin"
    con = ConsoleProcess("--machine", "chivu-lathe", "--output", f"parport+record://{record}?paced=0")
    api = con.client
    api.take_control()
    api.ok("POST", "/api/open", {"name": "long.ngc", "text": LONG_MOVE})
    api.ok("POST", "/api/run", {"speed": 1})
    api.wait(lambda s: s["state"] == "running" and "MOVING" in s["flags"] and s["time_s"] > 1.0, timeout=120)
    con.end(sig)
    data = np.fromfile(record, dtype=np.uint8)
    mask = step_mask(machine)
    assert (data & mask).any()                               # the run did pulse the step lines
    assert len(data) > 1.0 / machine.tick_s                  # ... for more than a second of machine time
    assert data[-1] == PinMap(machine).invert                # the last byte: every data pin at rest


def test_sigkill_leaves_no_recording_and_the_port_as_it_was(tmp_path):
    """SIGKILL cannot be caught: the recording is written when the output closes, so there is none.
    A real port would hold its last byte (a step line may be high, the enable on): only the drivers'
    own watchdog (a charge pump on the enable) or the microcontroller's heartbeat stops the machine."""
    record = tmp_path / "port.bin"
    con = ConsoleProcess("--machine", "chivu-lathe", "--output", f"parport+record://{record}?paced=0")
    api = con.client
    api.take_control()
    api.ok("POST", "/api/open", {"name": "long.ngc", "text": LONG_MOVE})
    api.ok("POST", "/api/run", {"speed": 1})
    api.wait(lambda s: s["state"] == "running" and s["time_s"] > 0.5, timeout=120)
    assert con.end(signal.SIGKILL) == -signal.SIGKILL
    assert not record.exists()


def test_serial_outputs_are_refused_at_start_up():
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "console", "--output", "serial+socket://127.0.0.1:9"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and proc.stdout == ""
    assert "serial+socket://127.0.0.1:9" in proc.stderr and "port frames" in proc.stderr


def test_a_non_loopback_listen_needs_allow_remote():
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "console", "--listen", "0.0.0.0:0"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "--allow-remote" in proc.stderr and proc.stdout == ""


def test_allow_remote_serves_every_interface_with_a_warning_and_still_checks_host():
    con = ConsoleProcess("--allow-remote", listen="0.0.0.0")
    try:
        assert con.client.state()["state"] == "ready"
        status, _ = con.client.call("GET", "/api/state", headers={"Host": f"rebind.example:{con.port}"})
        assert status == 403
    finally:
        con.end(signal.SIGTERM)
    warning = con.proc.stderr.read()
    assert "WARNING" in warning and "reachable from other computers" in warning


def enable_lathe(tmp_path):
    """chivu-lathe with its drivers' enable on pin 14, active low (the [parport] section)."""
    user = tmp_path / "lathe-enable.toml"
    user.write_text(Path(load_machine("chivu-lathe").source).read_text() + ENABLE_LOW)
    return load_machine(str(user))


def test_what_a_signal_does_turns_the_enable_off_and_rests_the_pins(tmp_path):
    """The signals' handler calls Console.make_safe: here mid-run, with the drivers' enable on pin 14."""
    machine = enable_lathe(tmp_path)
    record = tmp_path / "port.bin"
    con = Console(machine, [f"parport+record://{record}?paced=0"])
    con.open(name="long.ngc", text=LONG_MOVE)
    con.start(1.0)
    port = con.run.outputs[0].port
    for _ in range(3000):
        if con.state()["time_s"] > 0.5:
            break
        time.sleep(0.01)
    assert port.control_register & 0b10                      # pin 14 low (its inverted register bit set): enabled
    con.make_safe()
    assert port.control_register & 0b10 == 0                 # pin 14 high: the drivers are disabled
    data = np.fromfile(record, dtype=np.uint8)
    assert (data & step_mask(machine)).any() and data[-1] == PinMap(machine).invert
    assert con.state()["state"] == "stopped" and con.run.outputs == []


def test_an_exception_in_the_run_stops_it_puts_the_outputs_safe_and_stop_still_answers(tmp_path):
    machine = enable_lathe(tmp_path)
    record = tmp_path / "port.bin"
    served = Served(Console(machine, [f"parport+record://{record}?paced=0"]))
    try:
        served.take_control()
        served.ok("POST", "/api/open", {"name": "long.ngc", "text": LONG_MOVE})
        served.ok("POST", "/api/run", {"speed": 5})
        served.wait(lambda s: s["state"] == "running" and "MOVING" in s["flags"] and s["time_s"] > 0.5)
        run = served.console.run
        port = run.outputs[0].port
        assert port.control_register & 0b10                  # pin 14 low (its inverted register bit set): enabled

        def broken(limit):
            raise RuntimeError("a fault in the planner")
        run.ctl.run_until_idle = broken
        state = served.wait(lambda s: s["state"] == "error")
        assert "a fault in the planner" in state["fault"]
        assert port.control_register & 0b10 == 0             # pin 14 high: the drivers are disabled
        data = np.fromfile(record, dtype=np.uint8)
        assert (data & step_mask(machine)).any() and data[-1] == PinMap(machine).invert
        served.ok("POST", "/api/action", {"kind": "stop"})    # STOP answers in every state
        assert served.state()["state"] == "error"            # ... and the error stays shown
        served.ok("POST", "/api/run", {"speed": 0})           # and a new run can start
        served.wait(lambda s: s["state"] == "done")
    finally:
        served.close()


def test_a_controller_fault_puts_the_outputs_safe(tmp_path):
    record = tmp_path / "port.bin"
    con = Console(load_machine("chivu-lathe"), [f"parport+record://{record}?paced=0"])
    con.open(name="limit.cmds", text="FMOV X5 Z1\nFMOV X100 Z0\n")
    con.start(0)
    con.run.join(60)
    state = con.state()
    assert state["state"] == "error" and "outside the soft limits" in state["fault"]
    assert con.run.outputs == [] and record.exists()          # closed (the recording is written)
    assert np.fromfile(record, dtype=np.uint8)[-1] == PinMap(con.machine).invert
