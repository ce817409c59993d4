"""Write the firmware's machine header (firmware/machines/NAME.h) from a retrofit machine file.

    python3 firmware/tools/machine_header.py mitic-lathe > firmware/machines/mitic-lathe.h

The firmware compiles in what the Python side plans with: steps/mm, speed and acceleration
limits, backlash, pulse timing, feeds, switches, homing and the spindle encoder. Axes are listed
in the link's axis-bit order (X, Y, Z, A, ...) and drive the RAMPS socket of their letter (a
fourth axis: E0). The 002 switches go to the endstop connectors of ``SWITCH_CONNECTORS``; others
take the free connectors in order. A machine with a tool setter (``[setter]``) gets its beam as
the probe input (``PROBE_SWITCH``, kind SW_PROBE) on the next free connector after them.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from retrofit.controller.indexrun import INDEX_TIMEOUT_S  # noqa: E402
from retrofit.errors import RetrofitError  # noqa: E402
from retrofit.firmware.sim import firmware_axes, probe_connector, sockets, switch_connectors
from retrofit.link.codec import axis_bits  # noqa: E402
from retrofit.machine.config import Machine, load_machine  # noqa: E402

KINDS = {"limit": "SW_LIMIT", "home": "SW_HOME", "precise": "SW_PRECISE"}


def _float(value: float) -> str:
    """A C float literal: 1500.0f, 0.025f, 1e+06f."""
    text = f"{value:.7g}"
    return text + ("f" if "." in text or "e" in text else ".0f")


def _floats(values) -> str:
    return "{ " + ", ".join(_float(v) for v in values) + " }"


#: the most steps one line may have: its counts, shifted for AMASS (<< 6), fit 31 bits
LINE_MAX_STEPS = (1 << 24) - 1


def _ints(values) -> str:
    return "{ " + ", ".join(str(int(v)) for v in values) + " }"


def axis_lines(m: Machine, axes) -> list[str]:
    """N_AXES, the axis bits, sockets and per-axis arrays."""
    us = [m.tick_us * a.pulse_high_ticks for a in axes]
    period = [m.tick_us * (a.pulse_high_ticks + a.pulse_low_ticks) for a in axes]
    setup = [m.tick_us * max(a.dir_setup_ticks, 1) for a in axes]
    bits = axis_bits(m)
    socket_of = sockets(m)
    return [
        f"#define N_AXES              {len(axes)}",
        f"#define AXIS_LETTERS        \"{''.join(a.name for a in axes)}\"",
        f"#define AXIS_BITS           {_ints(bits[a.name] for a in axes)}"
        "   /* link mask bit of each axis */",
        "#define FOR_EACH_AXIS(M)   " + " ".join(f"M({i}, {socket_of[a.name]})" for i, a in enumerate(axes))
        + "   /* index, RAMPS socket */",
        f"#define DIR_INVERT          0x{sum(1 << i for i, a in enumerate(axes) if a.invert_dir):02X}",
        f"#define STEPS_PER_MM        {_floats(a.steps_per_mm for a in axes)}",
        f"#define MAX_RATE_STEPS_S    {_floats(a.max_velocity_mm_s * a.steps_per_mm for a in axes)}",
        f"#define ACCEL_STEPS_S2      {_floats(a.max_accel_mm_s2 * a.steps_per_mm for a in axes)}",
        f"#define BACKLASH_STEPS      {_ints(a.backlash_steps for a in axes)}",
        f"#define MIN_STEPS           {_ints(a.min_steps for a in axes)}   /* soft limits */",
        f"#define MAX_STEPS           {_ints(a.max_steps for a in axes)}",
        f"#define TRAVEL_STEPS        {_ints(math.ceil((a.max_mm - a.min_mm + 5) * 1.1 * a.steps_per_mm) for a in axes)}"
        "   /* the longest homing seek */",
        f"#define PULSE_HIGH_US       {math.ceil(max(us))}   /* 'dunu': the step pulse */",
        f"#define MIN_PERIOD_US       {math.ceil(max(period))}   /* 'perioada': the shortest step period */",
        f"#define DIR_SETUP_US        {math.ceil(max(setup))}",
    ]


def switch_lines(m: Machine, axes) -> tuple[list[str], dict[str, int]]:
    """The SWITCHES X-macro, one entry per switch of [switches] and the setter's beam (a probe
    input: no axis, no status bit); returns the switch ids too."""
    try:
        wired = switch_connectors(m)
        probe = probe_connector(m)
    except RetrofitError as exc:
        raise SystemExit(str(exc)) from None
    index = {a.name: i for i, a in enumerate(axes)}
    lines, ids = ["/* SWITCH(id, axis, side, kind, RAMPS endstop connector, status bit or -1) */",
                  "#define SWITCHES \\"], {}
    for i, (spec, connector, bit) in enumerate(wired):
        ids[spec.name] = i
        lines.append(f"    SWITCH({i}, {index[spec.axis]}, {spec.side:+d}, {KINDS[spec.kind]}, "
                     f"{connector}, {bit})   /* {spec.name.upper()} */ \\")
    if probe:
        lines.append(f"    SWITCH({len(wired)}, 0, +1, SW_PROBE, {probe}, -1)"
                     "   /* the tool setter's beam (no axis) */ \\")
    lines.append("")
    lines.append(f"#define N_SWITCHES          {len(wired) + bool(probe)}")
    lines.append(f"#define PROBE_SWITCH        {len(wired) if probe else 255}"
                 "   /* PROB watches it; 255: no probe input */")
    return lines, ids


def homing_lines(m: Machine, axes, ids: dict[str, int]) -> list[str]:
    """Homing order and per-axis seek switch, reference switch, home position, back-off, latch."""
    homing = m.parts.get("homing")
    order = [a.name for a in axes if homing and a.name in homing.order]
    if homing:
        order = list(homing.order)
    index = {a.name: i for i, a in enumerate(axes)}
    none = 255
    seek, ref, home, back, latch, dirs = [], [], [], [], [], []
    for a in axes:
        how = homing.axes.get(a.name) if homing else None
        spec = m.parts["switches"].named(how.switch) if how else None
        seek.append(ids[how.switch] if how else none)
        ref.append(ids[how.precise or how.switch] if how else none)
        home.append(round((how.home_mm if how else 0.0) * a.steps_per_mm))
        back.append(round((how.backoff_mm if how else 0.0) * a.steps_per_mm))
        latch.append(how.latch_mm_min if how else 30.0)
        dirs.append(spec.side if spec else 1)
    return [
        f"#define HOME_COUNT          {len(order)}",
        f"#define HOME_ORDER          {_ints([index[n] for n in order] + [0] * (len(axes) - len(order)))}",
        f"#define HOME_DIRS           {_ints(dirs)}",
        f"#define HOME_SEEK_SWITCH    {_ints(seek)}   /* 255: the axis is not homed */",
        f"#define HOME_REF_SWITCH     {_ints(ref)}",
        f"#define HOME_STEPS          {_ints(home)}   /* the position at the reference switch */",
        f"#define HOME_BACKOFF_STEPS  {_ints(back)}",
        f"#define HOME_LATCH_MM_MIN   {_floats(latch)}",
    ]


def header(m: Machine) -> str:
    """The whole header text; SystemExit for a machine the firmware cannot serve (an encoder
    faster than it follows: firmware/limits.toml)."""
    from retrofit.firmware.limits import check_encoder
    try:
        check_encoder(m)
        axes = firmware_axes(m)
        sockets(m)
    except RetrofitError as exc:
        raise SystemExit(str(exc)) from None
    for a in axes:                       # a line's steps are kept << 6 in 32-bit counters
        longest = max(a.max_steps - a.min_steps, math.ceil((a.max_mm - a.min_mm + 5) * 1.1 * a.steps_per_mm))
        if longest > LINE_MAX_STEPS:
            raise SystemExit(f"{m.source} [axis.{a.name.lower()}]: a line may take {longest} steps "
                             f"(soft limits or homing travel); the firmware takes at most {LINE_MAX_STEPS}")
    spindle = m.parts.get("spindle")
    switches, ids = switch_lines(m, axes)
    name = Path(m.source).name
    lines = [
        f"/* {m.name}.h - the settings of retrofit/machines/{name} the firmware compiles in.",
        " * Written by firmware/tools/machine_header.py (make machine MACHINE=" + m.name + ");",
        " * edit the machine file, not this header: a test checks that they agree. */",
        f"#define MACHINE_NAME        \"{m.name}\"",
        *axis_lines(m, axes),
        f"#define RAPID_FEED_MM_MIN   {_float(m.motion.rapid_feed_mm_min)}",
        f"#define DEFAULT_FEED_MM_MIN {_float(m.motion.default_feed_mm_min)}",
        f"#define JUNCTION_DEVIATION_MM {_float(m.motion.junction_deviation_mm)}",
        f"#define ENCODER_COUNTS_PER_REV {spindle.encoder_counts_per_rev if spindle else 0}",
        f"#define SPINDLE_MAX_RPM     {round(spindle.max_rpm) if spindle else 3000}UL",
        f"#define SPINDLE_SPEED_TOLERANCE {_float(spindle.speed_tolerance if spindle else 0.0)}"
        "   /* a thread is planned for a spindle this much faster */",
        f"#define SYNC_ACCEL_SHARE    {_float(spindle.sync_accel_share if spindle else 1.0)}"
        "   /* of the acceleration, for a thread's lead-in */",
        f"#define INDEX_TIMEOUT_MS    {round(INDEX_TIMEOUT_S * 1000)}UL"
        "   /* a thread pass without an index pulse this long: ERROR */",
        *switches,
        *homing_lines(m, axes, ids),
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: machine_header.py MACHINE (a shipped name or a .toml path)", file=sys.stderr)
        return 2
    sys.stdout.write(header(load_machine(argv[1])))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
