"""The console served to tests as the operator meets it: a real uvicorn server on a free port, its
token, and an HTTP client that can set any header (Host, Origin, Content-Type) as an attacker can;
and the page driven in a real headless Chromium (one setup for every browser test)."""

from __future__ import annotations

import http.client
import json
import secrets
import socket
import threading
import time
from pathlib import Path

import pytest

#: a long cut at F150 (16 s of machine time) between two rapids
LONG_MOVE = "G21 G90\nG0 X5 Z1\nG1 Z-39 F150\nG0 X10\nG0 Z5\nM30\n"
#: a tool change, a cut, a pause, a rapid
DIALOGS = "FMOV X5 Z1\nTOOL T2\nPMOV Z-3\nPAUS M0\nFMOV X8 Z2\n"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Served:
    """``console`` served by uvicorn in a thread on 127.0.0.1; ``call`` speaks to its API."""

    def __init__(self, console, **app_options):
        import uvicorn

        from retrofit.console.api import create_app
        self.console = console
        self.token = secrets.token_urlsafe(16)
        self.port = free_port()
        self.app = create_app(console, token=self.token, **app_options)
        self.server = uvicorn.Server(uvicorn.Config(self.app, host="127.0.0.1", port=self.port,
                                                    log_level="warning"))
        self.thread = threading.Thread(target=self.server.run, daemon=True)
        self.thread.start()
        for _ in range(1500):
            if self.server.started:
                break
            time.sleep(0.02)
        self.base = f"http://127.0.0.1:{self.port}"
        self.url = f"{self.base}/?token={self.token}"
        self.control: str | None = None

    def call(self, method: str, path: str, body=None, *, raw: bytes | None = None, headers: dict | None = None,
             control: str | None | bool = True) -> tuple[int, dict | str]:
        """(status, answer) of one request; ``headers`` override the defaults (None drops one)."""
        sent = {"Host": f"127.0.0.1:{self.port}", "X-Retrofit-Token": self.token}
        if method == "POST":
            sent["Content-Type"] = "application/json"
        ctl = self.control if control is True else (control or None)
        if ctl:
            sent["X-Retrofit-Control"] = ctl
        sent.update(headers or {})
        data = raw if raw is not None else (json.dumps(body).encode() if body is not None else None)
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=60)
        try:
            conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
            for key, value in sent.items():
                if value is not None:
                    conn.putheader(key, value)
            conn.putheader("Content-Length", str(len(data or b"")))
            conn.endheaders(data)
            resp = conn.getresponse()
            text = resp.read().decode(errors="replace")
        finally:
            conn.close()
        try:
            return resp.status, json.loads(text)
        except ValueError:
            return resp.status, text

    def ok(self, method: str, path: str, body=None, **kw) -> dict:
        status, answer = self.call(method, path, body, **kw)
        assert status == 200, (path, body, status, answer)
        return answer

    def take_control(self, take: bool = False) -> str:
        self.control = self.ok("POST", "/api/control", {"take": take}, control=None)["control"]
        return self.control

    def state(self) -> dict:
        return self.ok("GET", "/api/state")

    def wait(self, done, timeout: float = 90.0) -> dict:
        """Poll the state until ``done(state)``; the state."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            s = self.state()
            if done(s):
                return s
            time.sleep(0.05)
        raise AssertionError(f"state never satisfied the condition: {s}")

    def close(self) -> None:
        self.server.should_exit = True
        self.thread.join(20)
        self.console.close()


# -- the console and the reports in a real headless Chromium (Debian's, driven by Selenium) ------------
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
#: the mark of every browser test module: skipped where Chromium or its driver is missing
needs_chromium = pytest.mark.skipif(not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()),
                                    reason="needs Debian's chromium and chromium-driver")


def chromium(user_dir: Path, width: int = 1500, height: int = 1100):
    """Headless Chromium with a fresh profile and its network log on."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    opts = Options()
    opts.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run",
                f"--window-size={width},{height}", f"--user-data-dir={user_dir}"):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"performance": "ALL"})
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """One headless Chromium for the tests of a module."""
    driver = chromium(tmp_path_factory.mktemp("chromium-profile"))
    driver.set_script_timeout(120)
    yield driver
    driver.quit()


def wait_for(driver, script: str, timeout: float = 60.0):
    """Poll ``script`` in the page until it returns something true; that value."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = driver.execute_script(script)
        if value:
            return value
        time.sleep(0.05)
    seen = driver.execute_script("return [document.getElementById('state')?.textContent, "
                                 "document.getElementById('line')?.textContent, "
                                 "document.getElementById('time')?.textContent, "
                                 "document.getElementById('message')?.textContent]")
    raise AssertionError(f"page never satisfied: {script}; state, line, time, message: {seen}")


def console_page(driver, machine: str = "chivu-lathe") -> Served:
    """A console of ``machine`` served and open in ``driver``, the operator holding control."""
    from retrofit.console.server import Console
    from retrofit.machine.config import load_machine
    served = Served(Console(load_machine(machine)))
    driver.get(served.url)
    wait_for(driver, "return document.getElementById('example').options.length > 0 && "
                     "document.body.dataset.control === 'yours'")
    return served


def open_text(driver, name: str, text: str) -> None:
    """Open a program as the file picker would hand it over."""
    driver.execute_script("return openProgram({name: arguments[0], text: arguments[1]})", name, text)
    wait_for(driver, f"return document.getElementById('program-name').textContent === {name!r}")


def run(driver, speed: str) -> None:
    """Press Run at ``speed`` (0: as fast as it goes); returns once the run has begun or ended."""
    driver.execute_script(f"document.getElementById('speed').value = '{speed}'")
    before = driver.execute_script("return document.getElementById('time').textContent")
    driver.find_element("id", "run").click()
    wait_for(driver, "return ['running', 'held'].includes(document.getElementById('state').textContent) "
                     f"|| document.getElementById('time').textContent !== {before!r}")


def polls_later(driver, count: int, timeout: float = 120.0) -> None:
    """Return once the page has taken ``count`` more answers to its state polls (one every 100 ms:
    20 of them are 2 s of the page's own time, however slow the machine running the test)."""
    start = driver.execute_script("return +document.body.dataset.polls || 0")
    wait_for(driver, f"return (+document.body.dataset.polls || 0) >= {start + count}", timeout)
