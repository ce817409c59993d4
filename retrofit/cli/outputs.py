"""Sub-commands about outputs: ``retrofit outputs`` (URL grammars) and ``retrofit timing`` (paced loop)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from ..errors import RetrofitError
from . import machine_option


def add_commands(sub) -> None:
    o = sub.add_parser("outputs", help="list every output and its URL grammar")
    o.set_defaults(func=cmd_outputs)

    t = sub.add_parser("timing", help="run the paced real-time loop on the recorder; report its lateness",
                       description="Pace the circle demo's port bytes (repeated to fill --seconds) through "
                                   "the parport code path to the recorder and report how late each write was. "
                                   "It runs even when the calibration says the tick cannot be held, and says so.")
    machine_option(t, "chivu-lathe")
    t.add_argument("--seconds", type=float, default=10.0, help="length of the paced run (default 10)")
    t.add_argument("--tick-us", type=float, help="tick to pace at (default: the machine's tick_us)")
    t.add_argument("--every-tick", action="store_true", help="write every tick's byte, not only changes")
    t.add_argument("--output", metavar="URL",
                   help="a parport:// or parport+record:// URL to pace instead of a temporary recording")
    t.add_argument("--plot", metavar="FILE.png", help="save the lateness histogram as PNG")
    t.set_defaults(func=cmd_timing)


def cmd_outputs(args) -> int:
    from ..outputs import REGISTRY, output_class
    for scheme in sorted(REGISTRY):
        cls = output_class(scheme)
        print(f"{cls.grammar}\n    {cls.summary}")
        for name, (kind, default) in cls.options.items():
            print(f"    ?{name}=<{kind.__name__}>  (default {default!r})")
    return 0


def timing_url(args, folder: str) -> str:
    """The URL the timing run paces: --output, or a recording in ``folder``, with the options."""
    url = args.output or f"parport+record://{Path(folder) / 'timing.bin'}"
    if not url.startswith(("parport://", "parport+record://")):
        raise RetrofitError(f"--output {url}: timing paces a parallel port; expected parport://... "
                            "or parport+record://FILE")
    opts = [f"tick_us={args.tick_us:g}"] if args.tick_us else []
    opts += ["every_tick=1"] if args.every_tick else []
    opts += ["force=1"]                  # a timing run measures; the calibration's verdict is printed
    if opts:
        url += ("&" if "?" in url else "?") + "&".join(opts)
    return url


def cmd_timing(args) -> int:
    from ..demo import circle_targets
    from ..machine.config import load_machine
    from ..motion.errorloop import PositionErrorLoop
    from ..outputs import open_output
    from ..outputs.pacer import repeat_frames
    if not args.seconds > 0:
        raise RetrofitError(f"--seconds must be > 0 (got {args.seconds:g})")
    machine = load_machine(args.machine)
    log = PositionErrorLoop(machine).run(circle_targets(machine))
    with tempfile.TemporaryDirectory() as folder:
        out = open_output(timing_url(args, folder), machine)
        frames = repeat_frames(log.frames, max(1, round(args.seconds * 1e6 / (out.tick_ns / 1000))))
        out.quiet = True
        with out:
            out.write(frames)
    print(f"{machine.name}: circle demo repeated for {args.seconds:g} s through {out.url.text}")
    for line in out.report_lines():
        print(f"  {line}")
    if args.plot and out.timing.paced:
        print(f"  plot: {plot_lateness(out.timing, args.plot, machine.name)}")
    return 0


def plot_lateness(timing, path: str | Path, title: str = "") -> Path:
    """Histogram of the writes' lateness on log axes, with p50, p99 and half a tick marked."""
    import matplotlib
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    floor_us = 0.1
    late_us = np.maximum(np.asarray(timing.samples_ns, float) / 1000, floor_us)
    top = max(float(late_us.max()) if len(late_us) else 1.0, timing.tick_ns / 1000) * 1.5
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.hist(late_us, bins=np.geomspace(floor_us, top, 100), log=True, color="tab:blue")
    ax.set_xscale("log")
    for value_ns, label, style in ((timing.p50_ns, "p50", ":"), (timing.p99_ns, "p99", "-."),
                                   (timing.tick_ns / 2, "half a tick", "--")):
        ax.axvline(max(value_ns / 1000, floor_us), color="tab:red" if label == "half a tick" else "gray",
                   ls=style, label=f"{label} {value_ns / 1000:.1f} us")
    ax.set_xlabel(f"lateness of a write (us): actual - scheduled (below {floor_us} us drawn at {floor_us})")
    ax.set_ylabel("writes")
    ax.set_title(f"{title}: {timing.writes} writes at a {timing.tick_ns / 1000:g} us tick; "
                 f"max {timing.max_ns / 1000:.1f} us, {timing.late} later than half a tick", fontsize=10)
    ax.legend()
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
