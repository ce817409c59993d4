"""The console plays against an attacker over HTTP, on a real server: a foreign Host, a wrong or
missing token, a body that is not JSON, bad numbers, a second browser, racing starts and paths
outside the programs' folder are all refused, nothing moves, and STOP still stops afterwards."""

from __future__ import annotations

import os
import threading

import pytest
from console_kit import DIALOGS, LONG_MOVE, Served

from retrofit.console.server import Console
from retrofit.machine.config import load_machine


@pytest.fixture(scope="module")
def lathe():
    return load_machine("chivu-lathe")


@pytest.fixture
def served(lathe, tmp_path):
    programs = tmp_path / "programs"
    programs.mkdir()
    (programs / "part.ngc").write_text("; a part\nG0 X2 Z1\n")
    s = Served(Console(lathe, programs=programs))
    yield s
    s.close()


def moving(s):
    return s["state"] == "running" and s["time_s"] > 0.3


def test_the_page_is_served_without_the_token_but_the_api_never(served):
    status, page = served.call("GET", "/", headers={"X-Retrofit-Token": None})
    assert status == 200 and "<title>retrofit console</title>" in page
    for token in (None, "", served.token[:-1] + "x", served.token + "x"):
        status, answer = served.call("GET", "/api/machine", headers={"X-Retrofit-Token": token})
        assert status == 403 and "token" in answer["error"]
    status, _ = served.call("GET", f"/api/machine?token={served.token}", headers={"X-Retrofit-Token": None})
    assert status == 403                                     # the API reads the token from its header only
    assert served.ok("GET", "/api/machine")["name"] == "chivu-lathe"


@pytest.mark.parametrize("host", ["rebind.example.com:{port}", "127.0.0.1:1", "localhost", "192.168.1.9:{port}",
                                  None], ids=["foreign-name", "other-port", "no-port", "lan-address", "missing"])
def test_a_foreign_host_header_is_refused(served, host):
    headers = {"Host": host.format(port=served.port) if host else None}
    status, answer = served.call("GET", "/api/state", headers=headers)
    if host is None:                                         # HTTP/1.1 without Host: the server refuses it first
        assert status == 400 and "state" not in str(answer)
        return
    assert status == 403 and "Host" in answer["error"]
    status, _ = served.call("GET", "/", headers=headers)
    assert status == 403                                     # a rebound name gets not even the page


@pytest.mark.parametrize("host", ["127.0.0.1:{port}", "localhost:{port}", "[::1]:{port}"])
def test_the_loopback_names_of_the_listening_port_are_served(served, host):
    assert served.ok("GET", "/api/state", headers={"Host": host.format(port=served.port)})["state"] == "ready"


def test_a_foreign_origin_is_refused_even_with_the_token(served):
    served.take_control()
    for origin in ("http://evil.example", "null", f"http://localhost:{served.port + 1}", f"https://127.0.0.1:{served.port}"):
        status, answer = served.call("POST", "/api/open", {"name": "lathe-profile.ngc"}, headers={"Origin": origin})
        assert status == 403 and "Origin" in answer["error"]
    assert served.console.program is None
    assert served.ok("POST", "/api/open", {"name": "lathe-profile.ngc"},
                     headers={"Origin": f"http://127.0.0.1:{served.port}"})["name"] == "lathe-profile.ngc"


@pytest.mark.parametrize("ctype", ["text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x",
                                   None], ids=["text", "form", "multipart", "none"])
def test_a_body_that_is_not_json_is_refused_with_415(served, ctype):
    served.take_control()
    status, answer = served.call("POST", "/api/open", {"name": "lathe-profile.ngc"}, headers={"Content-Type": ctype})
    assert status == 415 and "application/json" in answer["error"]
    assert served.console.program is None


def test_json_with_a_charset_is_json(served):
    served.take_control()
    served.ok("POST", "/api/open", {"name": "lathe-profile.ngc"},
              headers={"Content-Type": "application/json; charset=utf-8"})


#: bodies that each once killed the run thread, and more like them
BAD_WHILE_RUNNING = [
    ("action", {"kind": "bogus"}), ("action", {"kind": "feed"}), ("action", {"kind": "feed", "pct": "x"}),
    ("action", {"kind": "feed", "pct": None}), ("action", {"kind": "feed", "pct": 0}),
    ("action", {"kind": "feed", "pct": 1000}), ("action", {"kind": "rapid", "pct": -5}),
    ("action", {"kind": "speed", "factor": "1"}), ("action", {"kind": "speed", "factor": 1e-300}),
    ("action", {"kind": "speed", "factor": -1}), ("action", {"kind": "stop", "now": True}),
    ("action", []), ("action", "stop"), ("action", None), ("run", {"speed": 1e-300}), ("run", {"speed": "1"}),
]
BAD_WHILE_STOPPED = [
    ("action", {"kind": "jog", "axis": "X", "step": "nan"}), ("action", {"kind": "jog", "axis": "X", "step": "inf"}),
    ("action", {"kind": "jog", "axis": "X", "step": 0}), ("action", {"kind": "jog", "axis": "X", "step": 1e6}),
    ("action", {"kind": "jog", "axis": "X", "step": 60}),         # 5 + 60 > the X limit of 40 mm
    ("action", {"kind": "jog", "axis": "Q", "step": 1}), ("action", {"kind": "jog", "axis": "X"}),
    ("action", {"kind": "jog", "step": 1}), ("action", {"kind": "mdi"}), ("action", {"kind": "mdi", "text": 5}),
    ("action", {"kind": "home", "axis": "X"}), ("action", {"kind": "answer", "yes": 1}),
]
RAW = [b'{"kind": "jog", "axis": "X", "step": NaN}', b'{"kind": "jog", "axis": "X", "step": Infinity}',
       b'{"kind": "jog", "axis": "X", "step": 1e999}', b'{"kind": "feed", "pct": 50', b"", b"\xff\xfe"]


def refused(served, path, body=None, raw=None):
    status, answer = served.call("POST", "/api/" + path, body, raw=raw)
    assert status == 400, (path, body, raw, status, answer)
    assert isinstance(answer["error"], str) and answer["error"] and "\n" not in answer["error"], answer


def test_bad_bodies_get_400_change_nothing_and_stop_still_stops(served):
    served.take_control()
    served.ok("POST", "/api/open", {"name": "long.ngc", "text": LONG_MOVE})
    served.ok("POST", "/api/run", {"speed": 1})           # 19 s of machine time: long enough for the bodies
    before = served.wait(moving)
    for path, body in BAD_WHILE_RUNNING:
        refused(served, path, body)
    for raw in RAW:
        refused(served, "action", raw=raw)
    after = served.wait(lambda s: s["time_s"] > before["time_s"] + 0.2)    # the run goes on, unchanged
    assert after["state"] == "running" and after["run_id"] == before["run_id"]
    assert (after["feed_pct"], after["rapid_pct"]) == (100.0, 100.0)
    stop_and_check(served)
    at = served.state()["commanded_mm"]
    for path, body in BAD_WHILE_STOPPED:
        refused(served, path, body)
    for raw in RAW:
        refused(served, "action", raw=raw)
    assert served.state()["commanded_mm"] == at                            # nothing moved
    served.ok("POST", "/api/action", {"kind": "jog", "axis": "X", "step": 1})
    served.wait(lambda s: s["state"] == "done" and s["commanded_mm"]["X"] == 1.0)
    served.ok("POST", "/api/run", {"speed": 1})                             # a new run starts
    served.wait(moving)
    stop_and_check(served)


def stop_and_check(served) -> None:
    """STOP answers, the state says stopped, and no step rises after the tick after STOP's."""
    served.ok("POST", "/api/action", {"kind": "stop"})
    served.wait(lambda s: s["state"] == "stopped")
    report = served.ok("GET", "/api/report")
    stop = [e["tick"] for e in report["events"] if e["kind"] == "stop"][-1]
    assert report["last_step_tick"] is not None and report["last_step_tick"] <= stop + 1


def test_bodies_over_the_limit_get_413(served):
    from retrofit.console.schema import ACTION_BYTES, PROGRAM_BYTES
    served.take_control()
    status, answer = served.call("POST", "/api/action", {"kind": "mdi", "text": "G0 X1" + " " * ACTION_BYTES})
    assert status == 413 and str(ACTION_BYTES) in answer["error"]
    status, answer = served.call("POST", "/api/open", {"name": "big.ngc", "text": "G0 X1\n" * (PROGRAM_BYTES // 6 + 1)})
    assert status == 413 and served.console.program is None


def test_sixteen_racing_starts_make_one_run(served):
    served.take_control()
    served.ok("POST", "/api/open", {"name": "long.ngc", "text": LONG_MOVE})
    gate, answers = threading.Barrier(16), []
    before = set(threading.enumerate())

    def start():
        gate.wait()
        answers.append(served.call("POST", "/api/run", {"speed": 1})[0])
    threads = [threading.Thread(target=start) for _ in range(16)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert sorted(answers) == [200] + [409] * 15
    assert served.state()["run_id"] == 1
    served.wait(moving)
    runs = [t for t in set(threading.enumerate()) - before if t.name == "retrofit-console-run"]
    assert len(runs) == 1                                    # one run thread was started, no orphan
    stop_and_check(served)
    runs[0].join(20)
    assert not runs[0].is_alive()                            # and it ticks no more after STOP


def test_a_second_browser_watches_until_it_takes_control_explicitly(served):
    first = served.take_control()
    served.ok("POST", "/api/open", {"name": "dialogs.cmds", "text": DIALOGS})
    served.ok("POST", "/api/run", {"speed": 0})
    served.wait(lambda s: s["dialog"] is not None)
    status, answer = served.call("POST", "/api/control", {"take": False}, control=None)
    assert status == 409 and "held by operator 1" in answer["error"] and answer["holder"]["name"] == "operator 1"
    second = "not-the-holders-id"
    for body in ({"kind": "answer"}, {"kind": "stop"}, {"kind": "feed", "pct": 10}, {"kind": "resume"}):
        status, answer = served.call("POST", "/api/action", body, control=second)
        assert status == 403 and "control" in answer["error"]
        status, _ = served.call("POST", "/api/action", body, control=None)
        assert status == 403
    watched = served.ok("GET", "/api/state", control=None)
    assert watched["dialog"]["kind"] == "tool" and watched["control"]["you"] is False
    assert watched["control"]["holder"]["name"]
    assert served.ok("GET", "/api/state")["control"]["you"] is True
    taken = served.ok("POST", "/api/control", {"take": True}, control=None)["control"]
    assert taken != first
    status, _ = served.call("POST", "/api/action", {"kind": "answer"}, control=first)
    assert status == 403                                     # the first browser now watches
    served.ok("POST", "/api/action", {"kind": "answer"}, control=taken)
    served.wait(lambda s: s["dialog"] is not None and s["dialog"]["kind"] == "pause")


REFUSALS = ["/etc/passwd", "../secret.ngc", "/proc/self/environ", "link.ngc", "nothing.ngc", "sub/../../secret.ngc",
            "%2e%2e/secret.ngc", "", "programs/../secret.ngc", "/dev/zero"]


def test_files_outside_the_programs_folder_get_one_refusal(served, tmp_path):
    (tmp_path / "secret.ngc").write_text("; the secret\n")
    os.symlink(tmp_path / "secret.ngc", tmp_path / "programs" / "link.ngc")
    served.take_control()
    answers = set()
    for name in REFUSALS:
        for key in ("name", "path"):
            status, answer = served.call("POST", "/api/open", {key: name})
            answers.add((status, str(answer)))
            assert "secret" not in str(answer) and "root:" not in str(answer)
    assert len(answers) == 1 and next(iter(answers))[0] == 404, answers
    assert served.console.program is None
    assert served.ok("POST", "/api/open", {"name": "part.ngc"})["listing"] == ["; a part", "G0 X2 Z1"]
    assert served.ok("POST", "/api/open", {"name": "lathe-profile.ngc"})["name"] == "lathe-profile.ngc"
    info = served.ok("GET", "/api/machine")
    assert "part.ngc" in info["programs"] and "link.ngc" not in info["programs"]


def test_control_lapses_only_when_its_holder_has_gone_quiet():
    from retrofit.console.guard import CONTROL_LAPSE_S, Control, Held
    now = [0.0]
    control = Control(clock=lambda: now[0])
    first, _ = control.claim(None, False, "127.0.0.1")
    now[0] += CONTROL_LAPSE_S * 0.9
    control.view(first)                                      # the holder's page polls
    now[0] += CONTROL_LAPSE_S * 0.9
    with pytest.raises(Held):
        control.claim(None, False, "127.0.0.2")
    now[0] += CONTROL_LAPSE_S * 1.1                          # its page closed: no poll since
    second, holder = control.claim(None, False, "127.0.0.2")
    assert second != first and holder["name"] == "operator 2"
    with pytest.raises(Held):
        control.check(first)
