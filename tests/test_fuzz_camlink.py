"""The CAM link server fuzzed: any bytes in any chunks, hostile clients, and it stays up.

In process, hypothesis sends byte streams of valid-looking and broken messages through the
splitter, the parser and the mill: only RetrofitErrors (answered ``!``) may come of them. Over
a socket, clients send random chunks, hang up mid-message or go silent; afterwards a fresh
client is served at once.
"""

from __future__ import annotations

import random
import socket

from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.camlink.client import CamClient
from retrofit.camlink.machine import CamMill
from retrofit.camlink.protocol import LineSplitter, parse_message
from retrofit.camlink.server import CamLinkServer
from retrofit.errors import LinkError, RetrofitError
from retrofit.machine.config import load_machine

MILL = load_machine("grenoble-mill")
WORDS = ["A", "JX", "JY", "JZ", "M1", "M0", "P1", "P0", "S150", "S-1", "S99999999999999999999",
         "F10", "T1 34", "T1 1e308", "H", "#", "1 1 1 1 1 1", "255 100 -255 -100 0 0",
         "0 9223372036854775808 0 0 0 0", "1e308 1 1 1 1 1", "nan 1 1 1 1 1", "", " ", "\x00",
         "\xff", "@@", "A" * 300]
MESSAGES = st.lists(st.one_of(st.sampled_from(WORDS), st.text(max_size=12)), max_size=30).map(
    lambda ws: "".join(w + "@" for w in ws).encode("utf-8", "surrogatepass"))


@settings(max_examples=150, deadline=None)
@given(stream=st.one_of(MESSAGES, st.binary(max_size=400)), cuts=st.lists(st.integers(1, 64)))
def test_any_bytes_in_any_chunks_give_replies_or_refusals_never_a_crash(stream, cuts):
    mill, splitter = CamMill(MILL), LineSplitter()
    pos, chunks = 0, []
    for n in cuts + [len(stream)]:
        chunks.append(stream[pos:pos + n])
        pos += n
    for chunk in chunks:
        for item in splitter.feed(chunk):
            try:
                if isinstance(item, LinkError):
                    raise item
                mill.handle(parse_message(item))
            except RetrofitError as exc:
                assert "\n" not in str(exc)
            mill.replies()
    positions = mill.positions()
    assert all(abs(p) < 10**9 for p in positions)


def test_hostile_clients_come_and_go_and_the_next_one_is_served_at_once():
    rng = random.Random(14)
    # the idle clock stands still: no client is dropped as idle, whatever the host's pace, so a
    # hostile client still held would refuse the next one
    with CamLinkServer(CamMill(MILL), "127.0.0.1", 0, clock=lambda: 0.0) as server:
        for _ in range(25):
            sock = socket.create_connection(server.address, timeout=60.0)
            for _ in range(rng.randint(0, 5)):
                sock.sendall(bytes(rng.randrange(256) for _ in range(rng.randint(1, 300))))
            if rng.random() < 0.5:
                sock.shutdown(socket.SHUT_WR)       # half-close mid-message
            sock.close()
        with CamClient(*server.address, timeout_s=60.0) as client:
            client.send_raw(b"A@")
            assert client.read_line() == "A"
