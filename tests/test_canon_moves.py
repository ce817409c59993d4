"""Moves kept as arrays after the seam read as the commands they stand for, and arcs cut into chords
all at once give each arc's chords, float for float."""

import copy
import math
import pickle
import random

import numpy as np

from retrofit.canon import ArcFeed, CommandCanon
from retrofit.canon.moves import FMOV, PFDR, PMOV, CommandList, Moves
from retrofit.commands import FMov, PFdr, PMov, Spin
from retrofit.motion.arcs import arc_columns, arcs_columns

NAMES = ("X", "Y", "Z")


def test_a_command_list_with_a_block_reads_as_the_list_of_its_commands():
    block = Moves(NAMES, np.array([FMOV, PFDR, PMOV, PMOV], np.int8),
                  np.array([[1.0, 2.0, -0.5], [650.0, 0.0, 0.0], [1.25, 2.0, -0.5], [3.0, -0.0, 7.0]]))
    listed = CommandList([Spin(1000.0, 1)])
    listed.add_block(block)
    listed.append(PMov((("X", 0.0), ("Y", 0.0), ("Z", 0.0))))
    want = [Spin(1000.0, 1), FMov((("X", 1.0), ("Y", 2.0), ("Z", -0.5))), PFdr(650.0),
            PMov((("X", 1.25), ("Y", 2.0), ("Z", -0.5))), PMov((("X", 3.0), ("Y", -0.0), ("Z", 7.0))),
            PMov((("X", 0.0), ("Y", 0.0), ("Z", 0.0)))]
    assert len(listed) == 6 and listed.parts()[1] is block           # counted, nothing made yet
    assert listed == want and list(listed) == want and listed[-2] == want[-2] and listed[1:3] == want[1:3]
    assert [str(c) for c in listed][1:3] == ["FMOV X1 Y2 Z-0.5", "PFDR F650"]
    assert copy.copy(listed) == want and pickle.loads(pickle.dumps(listed)) == want
    more = CommandList()
    more.add_block(block)
    listed.extend(more)
    listed += [Spin(0.0, 0)]
    assert len(listed) == 11 and listed[6:10] == want[1:5] and listed[-1] == Spin(0.0, 0)
    assert listed + [PFdr(1.0)] == list(listed) + [PFdr(1.0)]


def random_arcs(count: int, seed: int) -> list[tuple]:
    rnd = random.Random(seed)
    arcs = []
    for _ in range(count):
        plane = rnd.choice([(0, 1), (2, 0), (1, 2)])
        centre = [0.0] * 3
        centre[plane[0]], centre[plane[1]] = rnd.uniform(-50, 50), rnd.uniform(-50, 50)
        start = [rnd.uniform(-9, 9) for _ in range(3)]
        end = [rnd.uniform(-9, 9) if rnd.random() < 0.5 else start[j] for j in range(3)]
        radius, a0, a1 = rnd.uniform(0.01, 80), rnd.uniform(-4, 4), rnd.uniform(-4, 4)
        start[plane[0]], start[plane[1]] = centre[plane[0]] + radius * math.cos(a0), centre[plane[1]] + radius * math.sin(a0)
        radius *= rnd.choice([1.0, 1.0001, 0.9999])                        # spirals too
        end[plane[0]], end[plane[1]] = centre[plane[0]] + radius * math.cos(a1), centre[plane[1]] + radius * math.sin(a1)
        if rnd.random() < 0.1:                                             # full circles
            end[plane[0]], end[plane[1]] = start[plane[0]], start[plane[1]]
        arcs.append((tuple(start), tuple(end), tuple(centre), rnd.random() < 0.5, plane, rnd.choice([0, 0, 1])))
    return arcs


def test_arcs_cut_all_at_once_give_each_arcs_own_chords_float_for_float():
    arcs = random_arcs(300, 7)
    points, counts = arcs_columns(arcs, 0.01)
    assert len(counts) == 300 and counts.sum() == len(points) > 3000
    first = 0
    for arc, n in zip(arcs, counts.tolist()):
        alone = arc_columns(*arc[:5], 0.01, arc[5])
        got = points[first:first + n]
        assert np.array_equal(got, alone) and np.array_equal(np.signbit(got), np.signbit(alone)), arc
        first += n
    canon = CommandCanon(NAMES, 0.01)
    calls = [ArcFeed(start, end, centre, plane, cw, turns) for start, end, centre, cw, plane, turns in arcs[:40]]
    together = canon.chord_ends_of(calls)
    for call, ends in zip(calls, together):
        assert canon.chords(call) == [PMov(tuple(zip(NAMES, row))) for row in ends.tolist()]
        assert np.array_equal(ends, canon.chord_ends(call))


def test_the_planners_table_takes_a_block_as_the_commands_it_stands_for():
    from retrofit.gcode import compile_program
    from retrofit.machine.config import load_machine
    from retrofit.motion.planarrays import encode
    machine = load_machine("engraver")
    text = "G21 G90 G17 G91.1\nG0 X20 Y20 Z1\nG1 Z-1 F300\n" + "".join(
        f"X{20 + i % 9 * 0.5:.1f} Y{20 + i % 4 * 0.25:.2f}" + (" F500\n" if i % 13 == 0 else "\n")
        for i in range(60)) + "G1 X20 Y20\nG2 X25 Y25 I5 J0\nG0 Z5\nM2\n"
    commands = compile_program(text, machine).commands
    assert any(type(part) is Moves for part in commands.parts())
    got = encode(commands, machine)
    want = encode(list(commands), machine)
    assert all(np.array_equal(g, w, equal_nan=True) for g, w in zip(got, want))
