"""Ordinary job shapes through the streamed run: a Z move far ahead, pauses, long rasters.

Whole ``retrofit run PROGRAM --machine M --output sim:// --report r.json`` commands in fresh
processes, their CPU seconds (user + system) and peak RSS (``ru_maxrss`` of the child), medians
of ``--repeat`` runs with the contenders alternated:

* ``sc N``: Klipper's benchmark shape (``bench/square_circle.py``), plain; ``+Z``: with one
  final Z move up (``G92 Z-1`` first, ``G1 Z0`` last: Z rises 1 mm, against the generator's
  starting direction, so its direction turn is pending from the first move); ``+M0`` and
  ``+T1 M6``: with a pause in the middle (a manual tool change on this machine, nothing waits
  on ``sim://``);
* ``raster``: the engraver cuts a raster: a Z plunge, passes along X 150 mm apart by 0.05 mm in
  Y, a Z retract (about 1e7 and 3e7 steps);
* ``tiny2e6``: two million lines of 0.05 mm G1 moves on Klipper's machine (``bench/first_step.py``);
* ``cam1e6``: a million-line CAM program (``bench/gcode_speed.py``) on its mill.

Columns: this code; ``--previous DIR`` another checkout of retrofit (its ``XDG_CACHE_HOME`` by
``--previous-cache``, for its own ahead-of-time kernels); Klipper's whole batch process on the
``sc`` programs when ``KLIPPER_DIR`` is set (see ``bench/square_circle.py``).

    python bench/stream_shapes.py [--previous ../main] [--repeat 3] [--only sc500 raster1e7]
"""

from __future__ import annotations

import os

os.environ.setdefault("RETROFIT_READ_AHEAD", "1")     # the pipeline read ahead, window by window
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from square_circle import KLIPPER_CFG, LAUNCHER, chord_mm, klipper_gcode, machine, machine_file, workload_gcode  # noqa: E402

#: the CAM program's machine (bench/gcode_speed.py's): a mill without a tool changer
CAM_MACHINE = HERE.parent / "tests" / "gcode" / "rs274-mill.toml"


def sc_program(n: int, extra: str = "") -> str:
    """Klipper's shape, N times, with ``extra`` ("Z", "M0" or "T1 M6") added."""
    text = workload_gcode(n)
    if extra == "Z":
        return text.replace("G21 G90 G17\n", "G21 G90 G17\nG92 Z-1\n").replace("M2\n", "G1 Z0\nM2\n")
    if extra:
        lines = text.splitlines()
        middle = 3 + 6 * (n // 2)
        return "\n".join(lines[:middle] + [extra] + lines[middle:]) + "\n"
    return text


def raster_program(passes: int) -> str:
    """Plunge, ``passes`` X passes of 150 mm, 0.05 mm apart in Y, retract (12 004 steps a pass)."""
    lines = ["G21 G90 G17", "G0 X0 Y0", "G1 Z-0.5 F300", "F3000"]
    for i in range(passes):
        lines += [f"G1 X{150 if i % 2 == 0 else 0}", f"G1 Y{(i + 1) * 0.05:.2f}"]
    return "\n".join(lines + ["G0 Z0", "M2"]) + "\n"


def tiny_program(lines: int) -> str:
    """``lines`` lines of 0.05 mm G1 moves (``first_step.tiny_moves``), for Klipper's machine too."""
    from first_step import tiny_moves
    return tiny_moves(lines).replace("G21 G90 G17 F3000", "G21 G90 G17\nF3000")


def cam_lines(lines: int) -> str:
    """A CAM program of ``lines`` lines (``gcode_speed.cam_program``)."""
    from gcode_speed import cam_program
    return cam_program(lines)


WORKLOADS = {
    "sc500": ("sc", lambda: sc_program(500)),
    "sc500+Z": ("sc", lambda: sc_program(500, "Z")),
    "sc500+M0": ("sc", lambda: sc_program(500, "M0")),
    "sc500+T1M6": ("sc", lambda: sc_program(500, "T1 M6")),
    "raster1e7": ("engraver", lambda: raster_program(833)),
    "raster3e7": ("engraver", lambda: raster_program(2500)),
    "tiny2e6": ("sc", lambda: tiny_program(2_000_000)),
    "cam1e6": ("cam", lambda: cam_lines(1_000_000)),
}


def usage(argv: list[str], env: dict) -> tuple[str, float, float]:
    """(stdout, CPU seconds, peak RSS MB) of one fresh process, measured by a small launcher."""
    with tempfile.TemporaryDirectory() as folder:
        figures = Path(folder) / "usage.json"
        proc = subprocess.run([sys.executable, "-c", LAUNCHER, str(figures)] + argv, capture_output=True,
                              text=True, env=env, cwd=folder)          # not this folder: ``-m`` imports from it
        got = json.loads(figures.read_text()) if figures.exists() else {"code": proc.returncode}
    if got["code"] or proc.returncode:
        raise RuntimeError(f"{' '.join(argv[:4])} ... exited {got['code']}: {proc.stderr[-2000:]}")
    return proc.stdout, got["cpu"], got["rss_mb"]


def env_for(code: Path, cache: str | None) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "XDG_CACHE_HOME")}
    env["PYTHONPATH"] = str(code)
    if cache:
        env["XDG_CACHE_HOME"] = cache
    return env


def retrofit_run(program: Path, machine_arg: str, folder: Path, env: dict) -> tuple[float, float, int]:
    """CPU s, peak RSS MB and steps of one ``retrofit run`` to sim:// with a report."""
    report = folder / "r.json"
    argv = [sys.executable, "-m", "retrofit.cli", "run", str(program), "--machine", machine_arg,
            "--output", "sim://", "--report", str(report), "--progress", "off"]
    _, cpu, rss = usage(argv, env)
    steps = sum(a["steps"] for a in json.loads(report.read_text())["axes"].values())
    return cpu, rss, steps


def klipper_whole(text: str, folder: Path, arc_mm: float) -> tuple[float, float] | None:
    kdir = os.environ.get("KLIPPER_DIR")
    if not kdir:
        return None
    dictionary = os.environ.get("KLIPPER_DICT", os.path.join(kdir, "out", "klipper.dict"))
    cfg, gcode = folder / "printer.cfg", folder / "k.gcode"
    cfg.write_text(KLIPPER_CFG.format(arc_mm=f"{arc_mm:.4f}"))
    first = klipper_gcode(1).split("\n", 1)[0]                 # SET_KINEMATIC_POSITION: homed at 0
    body = text.replace("G21 G90 G17", "G21\nG90\nG17").replace("\nF3000", "\nG1 F3000")
    for word in ("M2", "M0", "T1 M6"):                          # the same motion: Klipper has no pauses here
        body = body.replace(word + "\n", "")
    gcode.write_text(first + "\n" + body)
    python = os.environ.get("KLIPPER_PYTHON", sys.executable)
    _, cpu, rss = usage([python, str(HERE / "klipper_batch.py"), kdir, str(cfg), str(gcode),
                         str(folder / "k.bin"), dictionary], dict(os.environ))
    return cpu, rss


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--previous", type=Path, help="another retrofit checkout to run side by side")
    parser.add_argument("--previous-cache", help="XDG_CACHE_HOME for the previous checkout's kernels")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--only", nargs="+", choices=sorted(WORKLOADS), default=list(WORKLOADS))
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp())
    sc_machine = str(machine_file(folder))
    this = env_for(HERE.parent, os.environ.get("XDG_CACHE_HOME"))
    sides = {"this": this}
    if args.previous:
        sides["previous"] = env_for(args.previous.resolve(), args.previous_cache)
    programs = {}
    for name in args.only:
        kind, make = WORKLOADS[name]
        machine_arg = {"sc": sc_machine, "cam": str(CAM_MACHINE)}.get(kind, "engraver")
        programs[name] = (folder / f"{name}.ngc", machine_arg, kind)
        programs[name][0].write_text(make())
    arc = chord_mm(machine())
    for env in sides.values():                                   # caches warm before timing
        retrofit_run(programs[args.only[0]][0], programs[args.only[0]][1], folder, env)
    klipper_whole(sc_program(1), folder, arc)                    # Klipper builds its C helper once
    got: dict = {}
    for _ in range(args.repeat):
        for name, (path, machine_arg, kind) in programs.items():
            for side, env in sides.items():
                got.setdefault((name, side), []).append(retrofit_run(path, machine_arg, folder, env))
            if kind == "sc":
                k = klipper_whole(path.read_text(), folder, arc)
                if k:
                    got.setdefault((name, "klipper"), []).append(k + (0,))
    print_table(got, programs, sides)


def print_table(got, programs, sides) -> None:
    med = {key: (statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs), runs[0][2])
           for key, runs in got.items()}
    heads = list(sides) + (["klipper"] if any(k[1] == "klipper" for k in med) else [])
    print(f"{'workload':12s} {'steps':>10s} | " + " | ".join(f"{h + ' CPU s':>16s} {'RSS MB':>7s}" for h in heads)
          + f" | {'M steps/CPU-s':>13s}")
    for name in programs:
        cells, steps = [], med[(name, "this")][2]
        for h in heads:
            cpu, rss, _ = med.get((name, h), (float("nan"), float("nan"), 0))
            cells.append(f"{cpu:16.2f} {rss:7.0f}")
        print(f"{name:12s} {steps:10d} | " + " | ".join(cells) + f" | {steps / med[(name, 'this')][0] / 1e6:13.1f}")
    ratio = lambda a, b: med[(a, "this")][0] / med[(b, "this")][0]            # noqa: E731
    for extra in ("sc500+Z", "sc500+M0", "sc500+T1M6"):
        if (extra, "this") in med and ("sc500", "this") in med:
            print(f"CPU {extra} / sc500: {ratio(extra, 'sc500'):.2f}")
    if ("raster3e7", "this") in med and ("raster1e7", "this") in med:
        print(f"CPU raster3e7 / raster1e7: {ratio('raster3e7', 'raster1e7'):.2f} "
              f"(steps {med[('raster3e7', 'this')][2] / med[('raster1e7', 'this')][2]:.2f}x)")


if __name__ == "__main__":
    main()
