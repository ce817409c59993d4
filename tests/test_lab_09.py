"""Lab 09 (the serial link): the reference passes every check, and every known-wrong solution in
wrong/ fails at least one, with the TODO the mistake belongs to among the failed checks."""

from pathlib import Path

import pytest

from retrofit.labs import check_lab, find_lab, load_module, result_lines

LAB = find_lab(Path(__file__).resolve().parent.parent / "labs", "09")
WRONG = sorted((LAB.path / "wrong").glob("*.py"))
#: which TODO each known-wrong solution gets wrong
TODO_OF = {"w01": 1, "w02": 1, "w03": 2, "w04": 2, "w05": 2, "w06": 2, "w07": 2, "w08": 3, "w09": 3,
           "w10": 4, "w11": 4, "w12": 5, "w13": 5}


def test_at_least_ten_known_wrong_solutions():
    assert len(WRONG) >= 10 and {p.name[:3] for p in WRONG} == set(TODO_OF)


@pytest.mark.parametrize("wrong", WRONG, ids=[p.stem for p in WRONG])
def test_known_wrong_solution_is_caught(wrong):
    results = check_lab(LAB, target=wrong)
    failed = [r for r in results if r.status == "failed"]
    assert failed, f"{wrong.name} passes every check:\n" + "\n".join(result_lines(results))
    assert f"TODO {TODO_OF[wrong.name[:3]]}" in {r.todo for r in failed}, "\n".join(result_lines(results))


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
