"""The console served to tests as the operator meets it: a real uvicorn server on a free port, its
token, and an HTTP client that can set any header (Host, Origin, Content-Type) as an attacker can."""

from __future__ import annotations

import http.client
import json
import secrets
import socket
import threading
import time

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
