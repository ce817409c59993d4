"""Benchmark: does the console make the paced port loop late? `retrofit timing` side by side.

Runs `retrofit timing` (the paced loop at the machine's tick, writing to the recorder) in three
conditions, alternating them ``--rounds`` times so that a drifting load on the computer hits each
alike, and prints the lateness of each run:

    alone       no console
    polled      `retrofit console` open in another process, its state polled ten times a second
                (by headless Chromium showing the page with --chromium, else by an HTTP poller)
    running     the same, while the console runs lathe-profile.ngc on sim:// paced at machine time

    python bench/console_timing.py [--seconds 5] [--rounds 2] [--chromium]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

LATENESS = re.compile(r"(\d+) writes at .*?lateness p50 ([\d.]+) us, p99 ([\d.]+) us, max ([\d.]+) us; (\d+) later")


def timing(seconds: float) -> dict:
    out = subprocess.run([sys.executable, "-m", "retrofit.cli", "timing", "--seconds", str(seconds)],
                         capture_output=True, text=True, check=True).stdout
    m = LATENESS.search(out)
    return {"writes": int(m[1]), "p50": float(m[2]), "p99": float(m[3]), "max": float(m[4]), "late": int(m[5])}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class OpenConsole:
    """`retrofit console` in a process of its own, and something polling it at 10 Hz."""

    def __init__(self, chromium: bool):
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.proc = subprocess.Popen([sys.executable, "-m", "retrofit.cli", "console", "--listen",
                                      f"127.0.0.1:{self.port}"], stdout=subprocess.PIPE, text=True)
        self.token = re.search(r"token=([\w-]+)", self.proc.stdout.readline())[1]
        self.headers = {"X-Retrofit-Token": self.token}
        for _ in range(100):
            try:
                urllib.request.urlopen(urllib.request.Request(self.base + "/api/machine", headers=self.headers),
                                       timeout=1)
                break
            except OSError:
                time.sleep(0.05)
        self.stop = threading.Event()
        self.polls = 0
        self.browser = None
        if chromium:
            self.browser = self._chromium()
        else:
            threading.Thread(target=self._poll, daemon=True).start()

    def post(self, path: str, body: dict) -> dict:
        req = urllib.request.Request(self.base + path, json.dumps(body).encode(),
                                     {"Content-Type": "application/json", **self.headers})
        return json.loads(urllib.request.urlopen(req, timeout=30).read())

    def _poll(self) -> None:
        while not self.stop.is_set():
            urllib.request.urlopen(urllib.request.Request(self.base + "/api/state", headers=self.headers), timeout=5).read()
            self.polls += 1
            self.stop.wait(0.1)

    def _chromium(self):
        from selenium import webdriver
        from selenium.webdriver.chrome.options import Options
        from selenium.webdriver.chrome.service import Service
        opts = Options()
        opts.binary_location = "/usr/bin/chromium"
        for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                    "--disable-component-update", "--disable-sync", "--no-first-run",
                    f"--user-data-dir={tempfile.mkdtemp(prefix='console-bench-')}"):
            opts.add_argument(arg)
        driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
        driver.get(f"{self.base}/?token={self.token}")  # the page polls /api/state every 100 ms
        return driver

    def run_program(self) -> None:
        self.headers["X-Retrofit-Control"] = self.post("/api/control", {"take": True})["control"]
        self.post("/api/open", {"name": "lathe-profile.ngc"})
        self.post("/api/run", {"speed": 1})

    def close(self) -> None:
        self.stop.set()
        if self.browser is not None:
            self.browser.quit()
        self.proc.terminate()
        self.proc.wait(10)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=5.0)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--chromium", action="store_true", help="poll with the real page in headless Chromium")
    p.add_argument("--settle", type=float, default=2.0, help="seconds between opening the console and timing")
    args = p.parse_args(argv)
    rows = []
    for r in range(args.rounds):
        for cond in ("alone", "polled", "running"):
            console = None
            if cond != "alone":
                console = OpenConsole(args.chromium)
                if cond == "running":
                    console.run_program()
                time.sleep(args.settle)           # measure the console open, not a browser starting
            try:
                rows.append((r + 1, cond, timing(args.seconds)))
            finally:
                if console is not None:
                    console.close()
    poller = "headless Chromium showing the page" if args.chromium else "an HTTP poller"
    print(f"retrofit timing, {args.seconds:g} s per run, console polled at 10 Hz by {poller}; "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    print(f"{'round':>5} {'condition':<9} {'writes':>7} {'p50 us':>8} {'p99 us':>9} {'max us':>9} {'late':>6}")
    for r, cond, t in rows:
        print(f"{r:>5} {cond:<9} {t['writes']:>7} {t['p50']:>8.1f} {t['p99']:>9.1f} {t['max']:>9.1f} {t['late']:>6}")
    for cond in ("alone", "polled", "running"):
        sel = [t for _, c, t in rows if c == cond]
        print(f"{cond:<8} median over rounds: p50 {statistics.median(t['p50'] for t in sel):7.1f} us, "
              f"p99 {statistics.median(t['p99'] for t in sel):8.1f} us, "
              f"late {statistics.median(t['late'] for t in sel):7.0f} of {sel[0]['writes']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
