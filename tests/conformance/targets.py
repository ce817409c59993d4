"""The two devices that speak docs/protocol.md: ``retrofit mcu`` and the firmware in simavr.

Each is started as a separate process serving TCP on 127.0.0.1; ``url`` is what pyserial opens
(``socket://127.0.0.1:PORT``). Both are killed by ``close()`` (the fixtures call it), and on Linux
also by the kernel if the test process itself dies first.
"""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FIRMWARE = ROOT / "firmware"
MACHINE = "mitic-lathe"
#: the devices every conformance test runs on: the Python controller and the compiled firmware in
#: simavr (cycle-exact, pins wired). QEMU (QemuTarget) is kept for a manual check only: it has no
#: GPIO, so switches, the encoder and the step pins cannot be seen, and its timers follow the
#: host's clock, so any timing under load is unreliable.
TARGETS = ["mcu", "firmware"]
#: what building and running the firmware needs
FIRMWARE_TOOLS = ("avr-gcc", "avr-objcopy", "make", "cc")


def missing_tools() -> list[str]:
    """The firmware tools not on PATH (empty when the firmware can be built and run)."""
    return [tool for tool in FIRMWARE_TOOLS if shutil.which(tool) is None]


def build_firmware(machine: str = MACHINE) -> Path:
    """``make`` in firmware/ (quietly); the path of firmware.elf. RuntimeError with make's output."""
    run = subprocess.run(["make", "-C", str(FIRMWARE), f"MACHINE={machine}", "firmware.elf"],
                         capture_output=True, text=True, timeout=300)
    if run.returncode != 0:
        raise RuntimeError(f"make in {FIRMWARE} failed:\n{run.stdout}\n{run.stderr}")
    return FIRMWARE / "firmware.elf"


def die_with_parent() -> None:
    """In the child, before exec: ask Linux to kill it when the test process dies, however."""
    if sys.platform.startswith("linux"):
        import ctypes
        import signal
        PR_SET_PDEATHSIG = 1
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Target:
    """A device process; ``name`` is "mcu" or "firmware"."""

    name = ""

    def __init__(self) -> None:
        self.proc: subprocess.Popen | None = None
        self.port = 0

    @property
    def url(self) -> str:
        return f"socket://127.0.0.1:{self.port}"

    @property
    def output_url(self) -> str:
        """The ``retrofit run --output`` URL of this device."""
        return f"serial+socket://127.0.0.1:{self.port}"

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
        if self.proc is not None:
            self.proc.wait(10)
            for stream in (self.proc.stdout, self.proc.stderr):
                if stream is not None:
                    stream.close()
        self.proc = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class McuTarget(Target):
    """``retrofit mcu --listen 127.0.0.1:0``; the port is read from what it prints."""

    name = "mcu"

    def __init__(self, machine: str = MACHINE, *options: str) -> None:
        super().__init__()
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        # a busy test machine may hold a host back longer than the 500 ms a real one is given;
        # the heartbeat itself is tested in tests/test_link_safety.py at its real 500 ms
        beat = () if any(o.startswith("--heartbeat-ms") for o in options) else ("--heartbeat-ms", "10000")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "retrofit.cli", "mcu", "--machine", machine, "--listen",
             "127.0.0.1:0", *beat, *options], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
            preexec_fn=die_with_parent)
        line = self.proc.stdout.readline()
        found = re.search(r"listening on 127\.0\.0\.1:(\d+)", line)
        if not found:
            err = self.proc.stderr.read() if self.proc.poll() is not None else ""
            self.close()
            raise RuntimeError(f"retrofit mcu did not say where it listens: {line!r} {err}")
        self.port = int(found.group(1))


class SimavrTarget(Target):
    """``retrofit firmware sim --listen 127.0.0.1:0``: the firmware in simavr at the board's pace."""

    name = "firmware"

    def __init__(self, machine: str = MACHINE, *options: str) -> None:
        super().__init__()
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "retrofit.cli", "firmware", "sim", "--machine", machine,
             "--listen", "127.0.0.1:0", *options], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env=env, preexec_fn=die_with_parent)
        line = self.proc.stdout.readline()
        found = re.search(r"listening on 127\.0\.0\.1:(\d+)", line)
        if not found:
            err = self.proc.stderr.read() if self.proc.poll() is not None else ""
            self.close()
            raise RuntimeError(f"retrofit firmware sim did not say where it listens: {line!r} {err}")
        self.port = int(found.group(1))

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()                       # the harness ends with it
        super().close()


class QemuTarget(Target):
    """The firmware in ``qemu-system-avr -machine mega2560``, its USART0 on a TCP server."""

    name = "firmware"

    def __init__(self, elf: Path) -> None:
        super().__init__()
        self.port = free_port()
        self.proc = subprocess.Popen(
            ["qemu-system-avr", "-machine", "mega2560", "-bios", str(elf), "-nographic",
             "-monitor", "none", "-serial",
             f"tcp:127.0.0.1:{self.port},server=on,wait=on,nodelay=on"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, preexec_fn=die_with_parent)
        self._wait_listening()

    def _wait_listening(self, timeout_s: float = 20.0) -> None:
        """QEMU waits for the first connection before it runs; wait until it listens."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if self.proc.poll() is not None:
                raise RuntimeError(f"qemu-system-avr exited: {self.proc.stderr.read()}")
            if f"127.0.0.1:{self.port}" in _listening_sockets():
                return
            time.sleep(0.05)
        self.close()
        raise RuntimeError(f"qemu-system-avr did not listen on port {self.port} in {timeout_s} s")


def _listening_sockets() -> str:
    """The local addresses of listening TCP sockets, from /proc (no connection is made)."""
    lines = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            with open(table) as fh:
                rows = fh.read().splitlines()[1:]
        except OSError:
            continue
        for row in rows:
            fields = row.split()
            if fields[3] != "0A":             # TCP_LISTEN
                continue
            addr, port = fields[1].split(":")
            if len(addr) == 8:
                ip = ".".join(str(int(addr[i:i + 2], 16)) for i in (6, 4, 2, 0))
                lines.append(f"{ip}:{int(port, 16)}")
    return " ".join(lines)
