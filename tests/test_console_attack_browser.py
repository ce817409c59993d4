"""A page of another origin, open in the operator's browser (headless Chromium), tries to move the
machine through the console: plain HTML forms (text/plain, the body shaped as JSON), no-cors
fetches and CORS fetches, each with the console's token in every place a page can put it. The
machine must not move: no run starts, no jog, no MDI, no answer to a dialog, no override."""

from __future__ import annotations

import functools
import http.server
import logging
import threading

import pytest
from console_kit import DIALOGS, LONG_MOVE, Served, browser, free_port, needs_chromium  # noqa: F401 (browser)

pytestmark = [needs_chromium, pytest.mark.slow]

ATTACKER = """<!DOCTYPE html><html><body><iframe name="sink" id="sink"></iframe><script>
function formPost(url, body) {          // a plain form: text/plain, "name=value", shaped as JSON
  return new Promise(done => {
    const cut = body.lastIndexOf("}"), f = document.createElement("form");
    f.method = "POST"; f.enctype = "text/plain"; f.action = url; f.target = "sink";
    const i = document.createElement("input");
    i.name = body.slice(0, cut) + ',"p":"'; i.value = '"}';
    f.appendChild(i); document.body.appendChild(f);
    document.getElementById("sink").onload = () => done("form loaded");
    setTimeout(() => done("form timeout"), 8000);
    f.submit();
  });
}
async function noCors(url, body, token) {
  try {
    await fetch(url, {method: "POST", mode: "no-cors", body: body,
                      headers: {"Content-Type": "application/json", "X-Retrofit-Token": token}});
    return "no-cors sent";
  } catch (e) { return "no-cors " + e; }
}
async function cors(url, body, token) {
  try {
    const r = await fetch(url, {method: "POST", body: body,
                                headers: {"Content-Type": "application/json", "X-Retrofit-Token": token}});
    return "cors " + r.status;
  } catch (e) { return "cors " + e; }
}
async function attack(base, token, path, body) {
  const url = base + path + "?token=" + token;
  return [await formPost(url, body), await noCors(url, body, token), await cors(url, body, token)];
}
</script></body></html>"""


@pytest.fixture(scope="module")
def attacker_site(tmp_path_factory):
    root = tmp_path_factory.mktemp("attacker")
    (root / "index.html").write_text(ATTACKER)
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(root))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", free_port()), handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    yield f"http://localhost:{httpd.server_address[1]}/index.html"
    httpd.shutdown()


@pytest.fixture
def served():
    from retrofit.console.server import Console
    from retrofit.machine.config import load_machine
    s = Served(Console(load_machine("chivu-lathe")))
    s.take_control()
    yield s
    s.close()


def attack(browser, served, path: str, body: str) -> list[str]:
    return browser.execute_async_script(
        "attack(arguments[0], arguments[1], arguments[2], arguments[3]).then(arguments[arguments.length - 1])",
        served.base, served.token, path, body)


MOVES = [("/api/run", '{"speed": 0}'), ("/api/action", '{"kind": "jog", "axis": "X", "step": 5}'),
         ("/api/action", '{"kind": "mdi", "text": "G0 X7 Z-2"}'), ("/api/action", '{"kind": "home"}'),
         ("/api/control", '{"take": true}'), ("/api/open", '{"name": "lathe-profile.ngc"}')]
STEERS = [("/api/action", '{"kind": "answer"}'), ("/api/action", '{"kind": "feed", "pct": 10}'),
          ("/api/action", '{"kind": "stop"}'), ("/api/control", '{"take": true}')]


def refused_at(caplog, path: str) -> int:
    """How many of the attacks on ``path`` reached the console and were refused for their Origin."""
    return sum(1 for r in caplog.records if r.name == "retrofit.console" and f" {path} " in r.getMessage()
               and "Origin" in r.getMessage())


def test_another_origins_page_cannot_start_jog_or_send_mdi(browser, served, attacker_site, caplog):
    caplog.set_level(logging.WARNING, logger="retrofit.console")
    served.ok("POST", "/api/open", {"name": "long.ngc", "text": LONG_MOVE})
    browser.get(attacker_site)
    for path, body in MOVES:
        outcome = attack(browser, served, path, body)
        assert outcome[0] == "form loaded" and outcome[1] == "no-cors sent", outcome
    for path in {p for p, _ in MOVES}:                       # the form and the no-cors fetch got there
        assert refused_at(caplog, path) >= 2 * sum(p == path for p, _ in MOVES)
    con = served.console
    assert con.run is None and con.run_id == 0                # no run started, no jog, no MDI, no home
    assert con.program.file == "long.ngc"
    state = served.state()
    assert state["state"] == "ready" and state["control"]["you"] is True


def test_another_origins_page_cannot_answer_a_dialog_or_steer(browser, served, attacker_site):
    served.ok("POST", "/api/open", {"name": "dialogs.cmds", "text": DIALOGS})
    served.ok("POST", "/api/run", {"speed": 0})
    served.wait(lambda s: s["dialog"] is not None)
    browser.get(attacker_site)
    for path, body in STEERS:
        attack(browser, served, path, body)
    state = served.state()
    assert state["dialog"]["kind"] == "tool" and state["commanded_mm"] == {"X": 5.0, "Z": 1.0}
    assert state["feed_pct"] == 100.0 and state["state"] == "running" and state["control"]["you"] is True
    assert [e["kind"] for e in served.console.run.events] == ["tool"]
    served.ok("POST", "/api/action", {"kind": "answer"})    # the operator's own answer goes through
    served.wait(lambda s: s["dialog"] is not None and s["dialog"]["kind"] == "pause")
