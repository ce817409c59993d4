"""The CAM link over a real TCP socket on 127.0.0.1: jobs, replies, pendant, robustness."""

import random
import select
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

from retrofit.camlink.client import CamClient, stream_job
from retrofit.camlink.machine import CamMill
from retrofit.camlink.protocol import (
    Auto,
    EndOperation,
    Home,
    Machining,
    Operation,
    Row,
    Spindle,
    format_message,
    is_reply,
    parse_position,
)
from retrofit.camlink.server import CamLinkServer, parse_listen
from retrofit.camlink.trajectory import arc_points, plan_rows
from retrofit.errors import LinkError
from retrofit.machine.config import load_machine

MILL = load_machine("grenoble-mill")
TOL = MILL.parts["servo"].in_position_pulses


@pytest.fixture
def served():
    mill = CamMill(MILL, record=True)
    server = CamLinkServer(mill, "127.0.0.1", 0).start()
    yield mill, server
    server.shutdown()


#: the most a reply or a change in the server's thread may take on a loaded machine (a ceiling)
CEILING_S = 60.0


def connect(server) -> CamClient:
    return CamClient(*server.address, timeout_s=CEILING_S)


def wait_for(condition, timeout_s=CEILING_S):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out waiting for the server"
        time.sleep(0.005)


class Clock:
    """The server's idle clock, moved only by the test: idleness is a matter of this clock, not
    of how fast the host runs the test."""

    def __init__(self):
        self.now_s = 0.0

    def __call__(self) -> float:
        return self.now_s


def roundtrip(client, text: str) -> str:
    client.send_raw(text.encode() + b"@")
    return client.read_line()


def distance_to_polyline(points, path) -> np.ndarray:
    """Distance of each point (pulses) to the polyline ``path`` (pulses)."""
    pts = np.asarray(points, float)
    best = np.full(len(pts), np.inf)
    for a, b in zip(path, path[1:]):
        a, b = np.asarray(a, float), np.asarray(b, float)
        d = b - a
        t = np.clip(((pts - a) @ d) / max(d @ d, 1e-12), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(pts - (a + t[:, None] * d), axis=1))
    return best


def test_a_client_machines_a_square_and_an_arc_and_the_mill_ends_where_it_should(served):
    mill, server = served
    square = [(20, 20, -5), (40, 20, -5), (40, 40, -5), (20, 40, -5), (20, 20, -5)]
    arc = arc_points((60, 20, -5), 20.0, 180.0, 0.0)            # from (40, 20) over the top to (80, 20)
    job = [Auto(), Machining(True), Home(), Operation(True), Spindle(150)]
    job += plan_rows(MILL, (0, 0, 0), [((20, 20, 0), 2400.0)] + [(p, 1200.0) for p in square])
    job += [EndOperation(), Operation(False)]
    job += plan_rows(MILL, square[-1], [((40, 20, -5), 1200.0)] + [(p, 600.0) for p in arc[1:]])
    job += [EndOperation(), Machining(False)]
    with connect(server) as client:
        result = stream_job(client, job)
    assert all(is_reply(line) for line in result.replies)
    assert result.replies[:2] == ["A", "H"] and len(result.replies) == 4
    for reported, wanted in zip(result.positions, [(20000, 20000, -5000), (80000, 20000, -5000)]):
        assert max(abs(r - w) for r, w in zip(reported, wanted)) <= TOL
    assert mill.positions() == result.positions[-1]
    trace = np.array(mill.trace, float)
    path = [(0, 0, 0), (20000, 20000, 0)]
    path += [tuple(1000 * c for c in p) for p in square + [(40, 20, -5)] + arc]
    assert distance_to_polyline(trace, path).max() < 100                    # < 0.1 mm, at corners
    on_arc = trace[trace[:, 0] > 40100]
    angle = np.degrees(np.arctan2(on_arc[:, 1] - 20000, on_arc[:, 0] - 60000))
    inside = on_arc[(angle > 10) & (angle < 170)]
    radial = np.hypot(inside[:, 0] - 60000, inside[:, 1] - 20000) - 20000
    assert len(inside) > 3000 and np.abs(radial).max() < 10                  # < 0.01 mm off the arc
    assert mill.spindle == 0 and not mill.coolant and not mill.machining


def test_each_message_does_what_the_paper_says(served):
    mill, server = served
    with connect(server) as client:
        assert roundtrip(client, "JX") == "JX" and mill.mode == "JX"
        assert roundtrip(client, "A") == "A"
        client.send_raw(b"M1@P1@S150@F200@T3 34@")
        assert roundtrip(client, "JY") == "A", "jog is ignored while machining: the mode stays auto"
        state = (mill.coolant, mill.spindle, mill.jog_feed, mill.tool, mill.tool_length_mm)
        assert state == (True, 150, 200, 3, 34)
        reply = roundtrip(client, "#")
        assert parse_position(reply) == (0, 0, 0) and not mill.coolant
        client.send_raw(b"M0@")
        assert roundtrip(client, "JY") == "JY" and mill.spindle == 0
        assert roundtrip(client, "H") == "H"


def test_the_joystick_jogs_only_in_jog_mode_and_the_position_is_sent_when_it_stops(served):
    mill, server = served
    with connect(server) as client:
        assert not mill.joystick(+1, 100), "auto mode: the joystick does nothing"
        assert roundtrip(client, "JX") == "JX"
        client.send_raw(b"F255@")
        wait_for(lambda: mill.jog_feed == 255)
        assert mill.joystick(+1, 200)
        x, y, z = parse_position(client.read_line())
        assert (x, y, z) == mill.positions() and y == z == 0
        assert abs(x - 10_000) <= TOL                   # 50 mm/s: 0.1 s ramps up and down, 0.1 s at speed
        assert roundtrip(client, "M1") == "A"
        assert not mill.joystick(-1, 100) and mill.positions()[0] == x


def test_emergency_stop_is_reported_and_refuses_motion_until_released(served):
    mill, server = served
    with connect(server) as client:
        client.send_raw(b"A@M1@P1@S200@")
        assert client.read_line() == "A"
        mill.press_estop()
        assert client.read_line() == "E1"
        assert (mill.spindle, mill.coolant, mill.operation) == (0, False, False)
        assert "emergency stop is pressed" in roundtrip(client, "0 0 0 0 0 0")
        assert "emergency stop is pressed" in roundtrip(client, "P1")
        mill.release_estop()
        assert client.read_line() == "E0"
        client.send_raw(b"P0@1 1 0 0 0 0@")
        assert parse_position(roundtrip(client, "#")) is not None


def malformed_lines(rng: random.Random, n: int) -> list[bytes]:
    """Lines the controller must refuse (no '@' inside), while an operation is open at home."""
    bad_bytes = [b for b in range(256) if b not in (9, 10, 13) and not 0x20 <= b <= 0x7E]
    printable = [b for b in range(0x21, 0x7F) if b != ord("@")]
    fixed = [b"Q12", b"G1 X5", b"Z", b"S-5", b"S", b"S1000", b"F300", b"T", b"T1", b"Tx 3", b"JQ",
             b"M5", b"P2", b"A1", b"H2", b"##", b"", b"   ", b"1.5 0 0 0 0 0", b"0 0 0 0 0",
             b"0 0 0 0 0 0 0", b"300 0 0 0 0 0", b"0 0 0 0 0 -9999999999999", b"0 -1 0 0 0 0",
             b"0 500 0 0 0 0", b"5 0 0 0 0 1", b"P1", b"- - - - - -"]
    lines = []
    for _ in range(n):
        kind = rng.randrange(5)
        if kind == 0:
            body = bytearray(rng.choice(printable + bad_bytes) for _ in range(rng.randrange(1, 60)))
            body[rng.randrange(len(body))] = rng.choice(bad_bytes)
            lines.append(bytes(body))
        elif kind == 1:
            lines.append(bytes(rng.choice(printable) for _ in range(rng.randrange(257, 700))))
        elif kind == 2:
            count = rng.choice([1, 2, 3, 4, 5, 7, 8, 12])
            lines.append(" ".join(str(rng.randrange(-300, 300)) for _ in range(count)).encode())
        elif kind == 3:
            big = [rng.randrange(-255, 256), rng.randrange(-10**9, 10**9)] * 3
            big[rng.randrange(6)] = rng.choice([256, -256, 2**31, -(2**33), 10**12])
            lines.append(" ".join(map(str, big)).encode())
        else:
            lines.append(rng.choice(fixed))
    return lines


def test_fuzz_1000_malformed_lines_each_get_an_error_and_move_nothing(served):
    mill, server = served
    with connect(server) as client:
        client.send_raw(b"A@M1@P1@S100@")
        assert client.read_line() == "A"
        before = (mill.tick, mill.positions(), mill.status()["drive"])
        lines = malformed_lines(random.Random(1), 1000)
        replies = []
        for start in range(0, len(lines), 50):
            client.send_raw(b"".join(line + b"@" for line in lines[start:start + 50]))
            replies += [client.read_line() for _ in lines[start:start + 50]]
        assert all(r.startswith("!") for r in replies) and len(replies) == 1000
        assert client.poll() == []
        assert (mill.tick, mill.positions(), mill.status()["drive"]) == before
        assert (mill.operation, mill.coolant, mill.spindle, mill.mode) == (True, True, 100, "A")
        client.send(Row((5, 0, 0), (1, 0, 0)))
        wait_for(lambda: mill.tick == before[0] + 1)
        assert parse_position(roundtrip(client, "#")) is not None


def test_errors_name_what_was_wrong_and_what_is_accepted(served):
    _, server = served
    with connect(server) as client:
        assert roundtrip(client, "S999") == "!'S999': spindle speed 999 out of range; accepted 0..255"
        assert roundtrip(client, "1 2 3") == "!'1 2 3': a row has 6 numbers 'fx px fy py fz pz', not 3"
        assert "outside an operation; send P1@ or P0@ first" in roundtrip(client, "0 0 0 0 0 0")
        assert "at most 256 bytes" in roundtrip(client, "7" * 300)
        assert roundtrip(client, "A") == "A"


def test_a_client_that_disconnects_mid_operation_stops_the_machine(served):
    mill, server = served
    rows = list(plan_rows(MILL, (0, 0, 0), [((100, 0, 0), 1200.0)]))[:2000]      # mid-move, 20 mm/s
    sock = socket.create_connection(server.address, timeout=CEILING_S)
    sock.sendall(b"A@")
    assert sock.recv(16) == b"A\n"
    sock.sendall(b"M1@P1@S150@" + b"".join(format_message(r) for r in rows))
    wait_for(lambda: mill.last_row_tick >= 2000)
    assert mill.axes[0].motor.speed_pulses_s > 15_000 and (mill.spindle, mill.coolant) == (150, True)
    sock.close()
    wait_for(lambda: mill.stops)
    stop = mill.stops[-1]
    assert stop.reason == "client disconnected"
    assert stop.tick == stop.last_row_tick, "drives at 0 from the first loop period after the last row"
    run_on = np.diff([p[0] for p in mill.trace[stop.tick - 1:]])              # pulses per period
    assert run_on.max() <= 20 and run_on[-1] == 0 and len(run_on) == stop.coast_periods
    assert (mill.spindle, mill.coolant, mill.operation, mill.drive()) == (0, False, False, (0, 0, 0))
    assert mill.at_rest() and 0 < stop.coast_pulses[0] < 200                  # ran on < 0.2 mm


def test_a_second_client_is_refused_clearly_and_the_first_carries_on(served):
    _, server = served
    with connect(server) as first:
        assert roundtrip(first, "A") == "A"
        with socket.create_connection(server.address, timeout=CEILING_S) as second:
            second.settimeout(CEILING_S)
            data = b""
            while not data.endswith(b"\n"):
                chunk = second.recv(1024)
                assert chunk, "the refusal comes before the close"
                data += chunk
            assert data.startswith(b"!busy:") and b"one client at a time" in data
            assert second.recv(1024) == b""                                     # then closed
        assert roundtrip(first, "JZ") == "JZ"


def test_a_refused_job_raises_and_stops_streaming(served):
    mill, server = served
    with connect(server) as client:
        with pytest.raises(LinkError, match="outside an operation"):
            stream_job(client, [Auto(), Row((0, 0, 0), (0, 0, 0))] + [EndOperation()])


def test_listen_address_must_be_host_and_port():
    assert parse_listen("127.0.0.1:0") == ("127.0.0.1", 0)
    with pytest.raises(LinkError, match="expected HOST:PORT"):
        parse_listen("localhost")


def test_retrofit_serve_prints_its_port_and_retrofit_send_streams_a_program(tmp_path, capsys):
    from retrofit.cli import main
    proc = subprocess.Popen([sys.executable, "-m", "retrofit.cli", "serve", "--listen", "127.0.0.1:0"],
                            stdout=subprocess.PIPE, text=True)
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 20.0)
        assert ready, "serve printed no address"
        line = proc.stdout.readline()
        port = int(line.rsplit(":", 1)[1])
        assert line.startswith("grenoble-mill: CAM link listening on 127.0.0.1:") and port > 0
        prog = tmp_path / "square.ngc"
        prog.write_text("G0 X10 Y10 Z-2\nM3 S1500\nG1 X20 F900\nG1 Y20\nG1 X10\nG1 Y10\nM5\nM2\n")
        assert main(["send", str(prog), "--to", f"127.0.0.1:{port}"]) == 0
        out = capsys.readouterr().out
        assert "ended at X10.000, Y10.000, Z-2.000 mm" in out
    finally:
        proc.terminate()
        proc.wait(timeout=CEILING_S)


def read_all(sock) -> bytes:
    """Everything the server sends until it closes the connection."""
    data = b""
    while True:
        chunk = sock.recv(4096)
        if not chunk:
            return data
        data += chunk


def test_a_silent_client_is_dropped_with_a_message_and_the_next_one_is_served():
    mill, clock = CamMill(MILL), Clock()
    with CamLinkServer(mill, "127.0.0.1", 0, idle_timeout_s=0.3, clock=clock) as server:
        silent = socket.create_connection(server.address, timeout=CEILING_S)
        wait_for(lambda: server.client is not None)
        # while the silent one holds the link, another is refused ...
        with socket.create_connection(server.address, timeout=CEILING_S) as other:
            assert read_all(other).startswith(b"!busy:")
        # ... until the server gives the silent one up, saying why
        clock.now_s += 0.31
        said = read_all(silent)
        silent.close()
        assert said.startswith(b"!idle: no message for 0.3 s;") and said.endswith(b"\n")
        assert mill.stops and mill.stops[-1].reason == "client idle for 0.3 s"
        with connect(server) as client:
            assert roundtrip(client, "A") == "A"


def test_a_client_that_keeps_talking_is_not_dropped_as_idle():
    mill, clock = CamMill(MILL), Clock()
    with CamLinkServer(mill, "127.0.0.1", 0, idle_timeout_s=0.3, clock=clock) as server:
        with connect(server) as client:
            for _ in range(12):                     # 12 exchanges 0.05 s apart: 0.6 s in all
                assert roundtrip(client, "A") == "A"
                clock.now_s += 0.05
            assert roundtrip(client, "A") == "A"
            assert not mill.stops
            clock.now_s += 0.31                     # then silent for longer than the timeout
            assert client.read_line().startswith("!idle: no message for 0.3 s;")
        assert mill.stops[-1].reason == "client idle for 0.3 s"


def test_a_reconnect_right_after_a_close_is_accepted(served):
    _, server = served
    for _ in range(40):
        sock = socket.create_connection(server.address, timeout=CEILING_S)
        sock.sendall(b"A@")
        assert sock.recv(16) == b"A\n"
        sock.close()                                # and at once the next connection
    with connect(server) as client:
        assert roundtrip(client, "JX") == "JX"


def test_the_idle_timeout_must_be_positive():
    with pytest.raises(LinkError, match="idle timeout -1 s: must be > 0"):
        CamLinkServer(CamMill(MILL), "127.0.0.1", 0, idle_timeout_s=-1)
