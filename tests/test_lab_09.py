"""Lab 09 (the serial link): the lab's point, measured on the reference solution (its wrong/ and
right/ variants are checked in tests/test_lab_wrong_solutions.py)."""

from pathlib import Path

from retrofit.lab.core import find_lab, load_module

LAB = find_lab(Path(__file__).resolve().parent.parent / "labs", "09")


def test_without_the_protocol_commands_are_lost_with_it_none():
    """The lab's point, measured: at 4 % flipped bytes raw sending loses commands, the protocol none."""
    import random

    from retrofit.link import encode_command
    solution = load_module(LAB.file(solution=True))
    commands = solution.moves()
    payloads = [encode_command(c, load_module(LAB.file(solution=True)).load_machine("chivu-lathe")) for c in commands]
    raw = solution.count_wrong(payloads, solution.send_raw(payloads, solution.FaultyWire(random.Random(1), flip=0.04)))
    delivered, stats = solution.run_protocol(commands, 0.04)
    assert raw >= 10 and delivered == commands and stats.resends >= 3
