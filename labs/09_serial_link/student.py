"""Lab 09 (your file): the serial link of the turning-machine controller — framing, CRC,
NAK and resend, measured on a noisy simulated line."""

from __future__ import annotations

import random
from pathlib import Path

from retrofit.commands import PMov
from retrofit.machine.config import load_machine
from retrofit.lab.core import pyplot, save_figure
from retrofit.link import DeviceEndpoint, Frame, FrameDecoder, HostEndpoint, crc32
from retrofit.link.framing import BadFrame, ESC, ESC_XOR, SOF
from retrofit.link.simwire import FaultyWire, LinkBench

MACHINE = "chivu-lathe"
FLIP_RATES = [0.0, 0.005, 0.01, 0.02, 0.03, 0.04]   # chance that a byte arrives with one bit flipped
COMMANDS = 60
MAX_TRIES = 40   # sends of one frame before the host gives up: at 4 % a frame and its ACK get
                 # through together about 4 times in 10, so the default 10 would sometimes give up


def stuff(body: bytes) -> bytes:
    """``body`` with every SOF and ESC byte replaced by ESC and the byte XOR ESC_XOR."""
    # TODO 1 (README, task 1): go through the bytes; SOF and ESC may not appear as themselves.
    raise NotImplementedError("TODO 1: write stuff(body): escape every SOF and ESC byte")

def frame(seq: int, payload: bytes) -> bytes:
    """The wire bytes of one frame: SOF, then the stuffed LEN, SEQ, payload and CRC (high byte first)."""
    # TODO 2 (README, task 2): the body is LEN, SEQ, payload; the CRC (crc32) covers
    # the body and follows it; what is stuffed, and what is not?
    raise NotImplementedError("TODO 2: write frame(seq, payload): the wire bytes of one frame")

def send_raw(payloads: list[bytes], wire: FaultyWire) -> list[bytes]:
    """Without a protocol: write each payload on the wire in turn; what arrives of each."""
    # TODO 3 (README, task 3): one write on the wire per command, as a host without a protocol does.
    raise NotImplementedError("TODO 3: write send_raw(payloads, wire): what arrives of each command")

def count_wrong(sent: list[bytes], received: list[bytes]) -> int:
    """How many commands arrived different from what was sent (cut short, or with a byte changed)."""
    # TODO 3: compare command by command.
    raise NotImplementedError("TODO 3: write count_wrong(sent, received): commands that arrived changed")

def refusals(seq: int, payload: bytes) -> dict[str, int]:
    """Flip every bit of the frame, one at a time, and give each damaged frame (then a SOF) to a fresh
    ``FrameDecoder``: of the flips it refused, how many for each reason (``BadFrame.reason``: length,
    crc, escape, truncated; ``lost`` when it gave no frame at all). A flip is refused when the decoder
    does not hand back ``Frame(seq, payload)``.
    """
    # TODO 4 (README, task 4): damage one bit at a time and give each damaged frame to a new
    # FrameDecoder; when is a flip refused, and for what reason?
    raise NotImplementedError("TODO 4: write refusals(seq, payload): single-bit flips refused, by reason")


def crc_catches(seq: int, payload: bytes) -> tuple[int, int]:
    """(single-bit flips the receiver refused, flips tried), from :func:`refusals`."""
    return sum(refusals(seq, payload).values()), 8 * len(frame(seq, payload))

def run_protocol(commands: list, flip: float, seed: int = 1):
    """With the protocol: send ``commands`` over two noisy wires; (commands delivered, host stats)."""
    # TODO 5 (README, task 5): a HostEndpoint and a DeviceEndpoint joined by a LinkBench whose two
    # FaultyWires flip bits at the rate ``flip``; the device's handler records what it delivers.
    raise NotImplementedError("TODO 5: write run_protocol(commands, flip): (delivered, host stats)")

def moves(count: int = COMMANDS) -> list:
    """``count`` short moves of X and Z, each one different."""
    return [PMov((("X", round(0.025 * (i % 40), 3)), ("Z", round(-0.02 * i, 3)))) for i in range(count)]


def plot_losses(out_dir) -> Path:
    """Commands that arrive wrong without the protocol, and with it, against the flip rate."""
    plt = pyplot()
    machine = load_machine(MACHINE)
    from retrofit.link import encode_command
    payloads = [encode_command(cmd, machine) for cmd in moves()]
    raw = [count_wrong(payloads, send_raw(payloads, FaultyWire(random.Random(1), flip=f))) for f in FLIP_RATES]
    framed = []
    for f in FLIP_RATES:
        delivered, _ = run_protocol(moves(), f)
        framed.append(sum(a != b for a, b in zip(moves(), delivered)) + abs(len(delivered) - COMMANDS))
    fig, ax = plt.subplots(figsize=(8, 4.5))
    rates = [100 * f for f in FLIP_RATES]
    ax.plot(rates, raw, "o-", color="tab:red", label="without the protocol: wrong, and nobody knows")
    ax.plot(rates, framed, "s-", color="tab:green", label="with framing, CRC, NAK and resend")
    ax.set_xlabel("bytes with a flipped bit (%)")
    ax.set_ylabel(f"commands wrong of {COMMANDS}")
    ax.set_title("What a noisy line does to the commands")
    ax.legend(loc="upper left")
    ax.grid(alpha=0.3)
    return save_figure(fig, out_dir, "losses.png")


def plot_cost(out_dir) -> Path:
    """What the guarantee costs: frames sent per command, and NAKs, against the flip rate."""
    plt = pyplot()
    sent, naks = [], []
    for f in FLIP_RATES:
        _, stats = run_protocol(moves(), f)
        sent.append(stats.frames_sent / COMMANDS)
        naks.append(stats.naks)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    rates = [100 * f for f in FLIP_RATES]
    ax.plot(rates, sent, "o-", color="tab:blue", label="frames sent per command")
    ax.set_xlabel("bytes with a flipped bit (%)")
    ax.set_ylabel("frames per command")
    ax.set_title("The price of the guarantee: resends")
    right = ax.twinx()
    right.plot(rates, naks, "s--", color="tab:orange", label="NAKs received")
    right.set_ylabel("NAKs (count)")
    fig.legend(loc="upper center", bbox_to_anchor=(0.35, 0.85))
    ax.grid(alpha=0.3)
    return save_figure(fig, out_dir, "cost.png")


def main(out_dir="out") -> list[Path]:
    """Measure the line with and without the protocol; draw both plots."""
    caught, tried = crc_catches(5, bytes(range(0x70, 0x80)))
    print(f"single-bit flips refused by the receiver: {caught} of {tried}")
    return [plot_losses(out_dir), plot_cost(out_dir)]


if __name__ == "__main__":
    for written in main(Path(__file__).parent / "out"):
        print(f"saved {written}")
