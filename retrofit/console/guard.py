"""Who may speak to the console: its token, its Host and Origin, JSON only, one operator in control.

``Guard`` is Starlette middleware in front of every route. It refuses, before any route runs:

- a ``Host`` header that is not the listening address (DNS rebinding) and an ``Origin`` header,
  when there is one, that is not ``http://`` + such an address (a page of another origin): 403;
- an ``/api/`` call without the console's token in the ``X-Retrofit-Token`` header: 403 (the
  page itself and its scripts are served without it);
- a POST whose ``Content-Type`` is not ``application/json``: 415.

Every refusal is logged (logger ``retrofit.console``) with what was refused. :class:`Control`
hands control to one browser at a time: the others watch, and taking control over is an act of
its own (``POST /api/control {"take": true}``).
"""

from __future__ import annotations

import hmac
import logging
import secrets
import socket
import threading
import time

from starlette.datastructures import Headers
from starlette.responses import JSONResponse

log = logging.getLogger("retrofit.console")

TOKEN_HEADER = "X-Retrofit-Token"
CONTROL_HEADER = "X-Retrofit-Control"
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
#: a holder not heard from for this long (s) has let control go: the next browser may claim it
CONTROL_LAPSE_S = 10.0


def is_loopback(host: str) -> bool:
    return host in ("localhost", "::1", "[::1]") or host.startswith("127.")


def host_names(listen_host: str, remote: bool) -> set[str]:
    """The host names (without port) a request may carry in Host for a console listening on
    ``listen_host``: the loopback names, and for a remote console its address and this computer's
    names and addresses."""
    names = set(LOOPBACK_NAMES)
    if remote:
        bare = listen_host.strip("[]")
        if bare not in ("0.0.0.0", "::", ""):
            names.add(f"[{bare}]" if ":" in bare else bare)
        else:
            for name in {socket.gethostname(), socket.getfqdn()}:
                names.add(name.lower())
                try:
                    names.update(info[4][0] for info in socket.getaddrinfo(name, None) if ":" not in info[4][0])
                except OSError:
                    pass
    return names


class Guard:
    """ASGI middleware: Host, Origin, token and Content-Type checks (see the module docstring)."""

    def __init__(self, app, token: str, names: set[str]):
        self.app, self.token, self.names = app, token.encode(), {n.lower() for n in names}

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        refusal = self.refusal(scope)
        if refusal is None:
            return await self.app(scope, receive, send)
        status, reason = refusal
        client = (scope.get("client") or ("?",))[0]
        log.warning("retrofit console: refused %s %s from %s: %s", scope["method"], scope["path"], client, reason)
        await JSONResponse({"error": reason}, status_code=status)(scope, receive, send)

    def refusal(self, scope) -> tuple[int, str] | None:
        """(status, reason) when the request is refused, else None."""
        headers = Headers(scope=scope)
        port = (scope.get("server") or (None, None))[1]
        allowed = {f"{name}:{port}" for name in self.names}
        host = headers.get("host", "").lower()
        if host not in allowed:
            return 403, (f"Host {host!r} is not this console's address; expected one of "
                         f"{', '.join(sorted(allowed))}")
        origin = headers.get("origin")
        if origin is not None and origin.lower() not in {f"http://{a}" for a in allowed}:
            return 403, f"Origin {origin!r} is not this console's page; only its own page may call it"
        if not scope["path"].startswith("/api/"):
            return None
        given = headers.get(TOKEN_HEADER.lower(), "").encode()
        if not hmac.compare_digest(given, self.token):
            return 403, (f"missing or wrong token: send the console's token in the {TOKEN_HEADER} header "
                         "(it is in the address the console printed)")
        if scope["method"] == "POST":
            media = headers.get("content-type", "").split(";")[0].strip().lower()
            if media != "application/json":
                return 415, f"Content-Type {media or 'missing'!r}: the console takes application/json only"
        return None


class Control:
    """Which browser holds control. ``claim`` hands out a control id; the holder shows it in the
    ``X-Retrofit-Control`` header of every call; ``check`` refuses a call from anyone else."""

    def __init__(self, clock=time.monotonic):
        self._lock = threading.Lock()
        self._clock = clock
        self._id: str | None = None
        self._holder: dict | None = None
        self._seen = 0.0
        self._count = 0

    def claim(self, caller: str | None, take: bool, address: str) -> tuple[str, dict]:
        """(control id, holder) for the caller; RetrofitError ``Held`` if another holds it and
        ``take`` is false."""
        with self._lock:
            if self._holds(caller):
                self._seen = self._clock()
                return self._id, dict(self._holder)
            if self._id is not None and not take and self._clock() - self._seen < CONTROL_LAPSE_S:
                raise Held(self.describe(), 409, self._holder)
            self._count += 1
            self._id = secrets.token_urlsafe(18)
            self._holder = {"name": f"operator {self._count}", "address": address,
                            "since": time.strftime("%H:%M:%S UTC", time.gmtime())}
            self._seen = self._clock()
            log.warning("retrofit console: control taken by %s (%s)", self._holder["name"], address)
            return self._id, dict(self._holder)

    def check(self, caller: str | None) -> None:
        """Nothing when ``caller`` holds control; else ``Held`` (status 403)."""
        with self._lock:
            if self._holds(caller):
                self._seen = self._clock()
                return
            held = self.describe() if self._id else ('no one holds control; take control first '
                                                     '(POST /api/control {"take": false})')
            raise Held(held, 403, self._holder)

    def view(self, caller: str | None) -> dict:
        """What a page shows: who holds control, and whether it is the caller."""
        with self._lock:
            you = self._holds(caller)
            if you:
                self._seen = self._clock()
            return {"holder": dict(self._holder) if self._holder else None, "you": you}

    def describe(self) -> str:
        h = self._holder
        return (f"control is held by {h['name']} ({h['address']}) since {h['since']}; this page watches; "
                'take control over with POST /api/control {"take": true}')

    def _holds(self, caller: str | None) -> bool:
        return self._id is not None and caller is not None and hmac.compare_digest(caller.encode(), self._id.encode())


class Held(Exception):
    """Control is held by another browser (status 409 for a claim, 403 for an action)."""

    def __init__(self, message: str, status: int, holder: dict | None):
        super().__init__(message)
        self.status, self.holder = status, dict(holder) if holder else None
