"""Benchmark: millions of commands through the serial link on a noisy simulated line.

Default rates: 2 % bit flips, 1 % dropped bytes, 0.5 % inserted bytes (per byte, each direction)
and 1 % duplicated writes, three copies in four arriving one to three writes late. Prints, for
all shards together, the commands lost, duplicated, corrupted and out of order (all must be 0),
the commands given up on, and then, side by side on the same faults, how many damaged frames a
CRC-16 (protocol version 1) and the CRC-32 (version 2) accept as good with changed contents.

    python bench/link_faults.py [--commands 10000000] [--shard 50000] [--workers 2]
                                [--crc-frames 1000000]
"""

from __future__ import annotations

import argparse
import sys
import time
from multiprocessing import Pool

from retrofit.link.faultbench import Tally, crc_escapes, run_faults

RATES = {"flip": 0.02, "drop": 0.01, "insert": 0.005}
DUPLICATE = 0.01


def shard(args: tuple[int, int]) -> Tally:
    seed, n = args
    return run_faults(n, seed=seed, duplicate=DUPLICATE, **RATES)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--commands", type=int, default=10_000_000)
    ap.add_argument("--shard", type=int, default=50_000, help="commands per independent run")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--crc-frames", type=int, default=1_000_000,
                    help="frames per check in the CRC-16 / CRC-32 comparison (0: skip)")
    args = ap.parse_args()
    jobs = [(seed, min(args.shard, args.commands - seed * args.shard))
            for seed in range((args.commands + args.shard - 1) // args.shard)]
    total, start = Tally(), time.perf_counter()
    print(f"link fault bench: {args.commands} commands in {len(jobs)} shards, rates {RATES}, "
          f"duplicate {DUPLICATE}", flush=True)
    with Pool(args.workers) as pool:
        for i, tally in enumerate(pool.imap_unordered(shard, jobs), 1):
            total.add(tally)
            if i % 10 == 0 or i == len(jobs):
                print(f"  {i}/{len(jobs)} shards, {total.commands} commands: lost {total.lost}, "
                      f"duplicated {total.duplicated}, corrupted {total.corrupted}, in order "
                      f"{total.in_order}, given up {total.given_up}", file=sys.stderr, flush=True)
    took = time.perf_counter() - start
    print(f"commands      {total.commands}")
    print(f"lost          {total.lost}")
    print(f"duplicated    {total.duplicated}")
    print(f"corrupted     {total.corrupted}")
    print(f"in order      {total.in_order}")
    print(f"wrong answers {total.wrong_answers}  (RDPS / RDST answered with another's reply)")
    print(f"given up      {total.given_up}  (not acknowledged after 60 tries)")
    print(f"frames sent   {total.frames_sent}; damaged frames refused by both ends "
          f"{total.bad_frames_seen}")
    print(f"wire faults   {total.wire}")
    print(f"simulated     {total.simulated_s:.0f} s of line time at 115 200 baud")
    print(f"host time     {took:.0f} s ({total.commands / took:.0f} commands/s, "
          f"{args.workers} workers)")
    if args.crc_frames:
        # the bench's faults, then frames with several flipped bits each (15 % of the bytes):
        # damage that single-error guarantees do not cover, where a check's width shows
        for title, rates in (("same faults", RATES), ("15 % of the bytes flipped",
                                                      {"flip": 0.15, "drop": 0.0, "insert": 0.0})):
            esc = crc_escapes(args.crc_frames, seed=99, **rates)
            print(f"\n{title}, {esc.frames} frames per check, {esc.damaged} damaged:")
            for kind, passed in esc.passed.items():
                print(f"  {kind}: {passed} damaged frames accepted as good "
                      f"({passed / max(esc.damaged, 1):.2e} per damaged frame)")
    bad = total.lost or total.duplicated or total.corrupted or not total.in_order
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
