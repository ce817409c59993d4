"""Checks of lab 10 (G-code to motion): run with `retrofit lab check 10`, or pytest on this file.

The oracles: for the lab's programs, the moves LinuxCNC's interpreter gave (recorded in
programs/*.canon; retrofit's interpreter agrees where it runs them); for programs drawn at random
(seeded: RETROFIT_CHECK_SEED draws them again) and written in every spacing and case RS274NGC
allows, an interpreter of the lab's words written here, which agrees with LinuxCNC on the lab's
programs (a check of the checks).
"""

import re
from pathlib import Path

import pytest

from retrofit.lab.check import borrowed, cases, seed_note
from retrofit.lab.core import expect, load_target, target_path

PROGRAMS = Path(__file__).resolve().parent / "programs"
NAMES = sorted(p.stem for p in PROGRAMS.glob("*.ngc"))
_CANON = re.compile(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED|SET_FEED_RATE)\(([^)]*)\)")


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


def recorded(name):
    """(kind, x, y, z, feed) of every move LinuxCNC's interpreter made of programs/NAME.ngc."""
    moves, feed = [], 0.0
    for call, args in _CANON.findall((PROGRAMS / f"{name}.canon").read_text(encoding="utf-8")):
        numbers = [float(a) for a in args.split(",")]
        if call == "SET_FEED_RATE":
            feed = numbers[0]
        else:
            kind = "rapid" if call == "STRAIGHT_TRAVERSE" else "feed"
            moves.append((kind, *numbers[:3], feed if kind == "feed" else 0.0))
    return moves


def by_retrofit(name):
    """The same moves from retrofit's interpreter on the mill, or None where it refuses the program."""
    from retrofit.commands import FMov, PFdr, PMov
    from retrofit.machine.config import load_machine
    from retrofit.errors import RetrofitError
    from retrofit.gcode.program import compile_program
    try:
        program = compile_program((PROGRAMS / f"{name}.ngc").read_text(encoding="utf-8"), load_machine("tul-mill"))
    except RetrofitError:
        return None
    moves, feed = [], 0.0
    for cmd in program.commands:
        if isinstance(cmd, PFdr):
            feed = cmd.feed
        elif isinstance(cmd, (FMov, PMov)):
            axes = dict(cmd.axes)
            kind = "rapid" if isinstance(cmd, FMov) else "feed"
            moves.append((kind, axes["X"], axes["Y"], axes["Z"], feed if kind == "feed" else 0.0))
    return moves


def _same(got, want):
    return len(got) == len(want) and all(
        g[0] == w[0] and all(abs(a - b) < 1e-6 for a, b in zip(g[1:], w[1:])) for g, w in zip(got, want))


def _moves(lab, name):
    return [(m.kind, m.x, m.y, m.z, m.feed) for m in lab.interpret((PROGRAMS / f"{name}.ngc").read_text())]


def test_words_of_a_block(lab):
    """TODO 1: parse_words reads letters and signed decimal numbers, with or without spaces"""
    for line, want in [("G1 X10 F200", [("G", 1.0), ("X", 10.0), ("F", 200.0)]),
                       ("g81x-5.5y.5 z-3 r2", [("G", 81.0), ("X", -5.5), ("Y", 0.5), ("Z", -3.0), ("R", 2.0)]),
                       ("G91 X-5 Y+5", [("G", 91.0), ("X", -5.0), ("Y", 5.0)])]:
        got = lab.parse_words(line)
        expect([(a, float(b)) for a, b in got] == want, f"parse_words({line!r})", expected=want, got=got,
               hint="lower case letters count too; a number may start with a sign or a point")


def test_target_absolute_and_incremental(lab):
    """TODO 2: target() in G90 replaces the named axes, in G91 adds to them; the others stay"""
    state = lab.State(x=5.0, y=-2.0, z=7.0)
    got = tuple(lab.target(state, {"X": 1.0, "Z": -3.0}))
    expect(got == (1.0, -2.0, -3.0), "target() in G90 from (5, -2, 7) with X1 Z-3", expected=(1.0, -2.0, -3.0), got=got)
    state.absolute = False
    got = tuple(lab.target(state, {"X": 1.0, "Z": -3.0}))
    expect(got == (6.0, -2.0, 4.0), "target() in G91 from (5, -2, 7) with X1 Z-3", expected=(6.0, -2.0, 4.0), got=got,
           hint="in G91 a number is a distance from where the tool is")


HOLES = [  # state (x, y, z, r, depth, G98?), hole (x, y), moves worked by hand
    ((0, 0, 5, 2, -3, False), (10, 5), [("rapid", 10, 5, 5), ("rapid", 10, 5, 2), ("feed", 10, 5, -3), ("rapid", 10, 5, 2)]),
    ((0, 0, 8, 1, -2, True), (5, 5), [("rapid", 5, 5, 8), ("rapid", 5, 5, 1), ("feed", 5, 5, -2), ("rapid", 5, 5, 8)]),
    ((0, 0, -1, 3, -5, True), (4, 0), [("rapid", 0, 0, 3), ("rapid", 4, 0, 3), ("feed", 4, 0, -5), ("rapid", 4, 0, 3)]),
    ((10, 5, 2, 2, -3, False), (20, 5), [("rapid", 20, 5, 2), ("feed", 20, 5, -3), ("rapid", 20, 5, 2)]),
]


@pytest.mark.parametrize("start,hole,want", HOLES, ids=["above-G99", "above-G98", "below-R", "at-R"])
def test_one_hole_worked_by_hand(lab, start, hole, want):
    """TODO 3: g81_moves gives the hole's moves: XY at a safe height, R, feed to depth, retract"""
    x, y, z, r, depth, g98 = start
    state = lab.State(motion="G81", retract_to_start=g98, feed=100.0, x=x, y=y, z=z, r=r, depth=depth)
    got = [(m.kind, m.x, m.y, m.z) for m in lab.g81_moves(state, *hole)]
    hint = ("G98 retracts to the higher of the starting Z and R; G99 to R" if len(got) == len(want) else
            "below R the tool first rises to R; at R there is no rapid down to it")
    expect(_same([g + (0,) for g in got], [w + (0,) for w in want]),
           f"the moves of a G81 hole at {hole} from Z{z} with R{r} Z{depth} {'G98' if g98 else 'G99'}",
           expected=want, got=got, hint=hint)
    feeds = [m.feed for m in lab.g81_moves(state, *hole) if m.kind == "feed"]
    expect(feeds == [100.0], "the drilling move's feed", expected="[100.0], the modal F", got=feeds)


@pytest.mark.parametrize("name", NAMES)
def test_program_moves_match_the_interpreter(lab, name):
    """TODO 4: interpret() gives the moves of each program, as LinuxCNC's interpreter gave them"""
    want, oracle = recorded(name), "LinuxCNC's interpreter (programs/*.canon)"
    got = _moves(lab, name)
    first = next((i for i, (g, w) in enumerate(zip(got, want)) if not _same([g], [w])), min(len(got), len(want)))
    expect(_same(got, want), f"the moves of {name}.ngc against {oracle}",
           expected=f"{len(want)} moves; move {first + 1}: {want[first] if first < len(want) else 'none'}",
           got=f"{len(got)} moves; move {first + 1}: {got[first] if first < len(got) else 'none'}",
           hint="modal: G0/G1/G81, G90/G91, G98/G99 and F stay until changed; a block with only "
                "X/Y repeats the cycle there; G80 ends it")


def test_g80_ends_the_cycle(lab):
    """TODO 4: after G80, axis words with no G0 or G1 are refused (ValueError), as LinuxCNC refuses them"""
    text = "G90 G99 G0 X0 Y0 Z5\nF100\nG81 X1 Y1 Z-1 R1\nG80\nX5\n"
    try:
        moves = lab.interpret(text)
    except ValueError:
        return
    expect(False, "interpret() of a program that names X5 after G80", expected="ValueError: no motion mode",
           got=f"{len(moves)} moves, the last {moves[-1] if moves else None}",
           hint="G80 cancels the motion mode; a block with only axis words then has nothing to do")


def words_here(line):
    """The words of a block, read here: spaces and tabs dropped (RS274NGC ignores them), any case."""
    block, words, k = "".join(line.split()).upper(), [], 0
    while k < len(block):
        letter, k = block[k], k + 1
        start = k
        while k < len(block) and (block[k].isdigit() or block[k] in ".+-" and (k == start or block[k] == ".")):
            k += 1
        words.append((letter, float(block[start:k])))
    return words


def interpret_here(text):
    """The lab's interpreter, written here from the handout: (kind, x, y, z, feed) of every move."""
    at, mode, absolute, back_to_start, feed, r, depth = [0.0, 0.0, 0.0], "G0", True, True, 0.0, 0.0, 0.0
    moves = []
    for line in text.splitlines():
        words = words_here(line)
        g = [v for letter, v in words if letter == "G"]
        given = {letter: v for letter, v in words if letter != "G"}
        for code in g:
            absolute = {90: True, 91: False}.get(code, absolute)
            back_to_start = {98: True, 99: False}.get(code, back_to_start)
            mode = {0: "G0", 1: "G1", 80: None, 81: "G81"}.get(code, mode)
        feed = given.get("F", feed)
        if not {"X", "Y", "Z"} & set(given):
            continue
        end = [given.get(a, at[i]) if absolute else at[i] + given.get(a, 0.0) for i, a in enumerate("XYZ")]
        if mode == "G81":
            r, depth = given.get("R", r), given.get("Z", depth)
            top = max(at[2], r) if back_to_start else r
            z = at[2]
            if z < r:
                moves.append(("rapid", at[0], at[1], r, 0.0))
                z = r
            moves.append(("rapid", end[0], end[1], z, 0.0))
            if z != r:
                moves.append(("rapid", end[0], end[1], r, 0.0))
            moves += [("feed", end[0], end[1], depth, feed), ("rapid", end[0], end[1], top, 0.0)]
        elif mode in ("G0", "G1"):
            moves.append(("rapid" if mode == "G0" else "feed", *end, feed if mode == "G1" else 0.0))
        else:
            raise ValueError("axis words after G80")
        at = list(moves[-1][1:4])
    return moves


def _number(rng, value, leading_zero=False):
    """``value`` written as RS274NGC allows: a + sign, a trailing point, no leading 0, spaces inside."""
    text = f"{value:.3f}".rstrip("0")
    text = text + ("0" if rng.random() < 0.5 else "") if text.endswith(".") else text
    if text.endswith(".0") and rng.random() < 0.5:
        text = text[:-2] + rng.choice(["", "."])
    if text.startswith(("0.", "-0.")) and text[-1].isdigit() and text.rstrip("0") != text.split(".")[0] + "." \
            and rng.random() < 0.5:
        text = text.replace("0.", ".", 1)
    if leading_zero and rng.random() < 0.5:
        text = "0" + text
    if not text.startswith("-") and rng.random() < 0.2:
        text = "+" + text
    if len(text) > 2 and rng.random() < 0.25:
        k = rng.randrange(1, len(text))
        text = text[:k] + rng.choice([" ", "\t"]) + text[k:]
    return text


def _render(rng, block):
    """One block, its words in the order given, in random case and spacing."""
    out = []
    if rng.random() < 0.2:
        out.append(f"N{rng.randint(1, 9999)}")
    for letter, value in block:
        letter = letter.lower() if rng.random() < 0.4 else letter
        out.append(letter + rng.choice(["", "", " ", "  ", "\t"]) + _number(rng, value, leading_zero=letter in "Gg"))
    return rng.choice(["", " ", "\t"]) + "".join(w + rng.choice(["", " ", " ", "   ", "\t"]) for w in out)


def random_program(rng):
    """Blocks of the lab's words: moves in G90 and G91, F changes, G81 holes with G98 or G99, G80."""
    def coord():
        return round(rng.uniform(-50, 50), rng.choice([0, 1, 3]))
    blocks = [[("G", 90), ("G", 0), ("X", coord()), ("Y", coord()), ("Z", round(rng.uniform(2, 20), 1))]]
    for _ in range(rng.randint(6, 18)):
        kind = rng.random()
        if kind < 0.35:
            axes = rng.sample("XYZ", rng.randint(1, 3))
            block = ([("G", rng.choice([0, 1]))] if rng.random() < 0.7 else []) + [(a, coord()) for a in axes]
            if rng.random() < 0.3:
                block.append(("F", float(rng.randint(20, 900))))
            blocks.append(block)
        elif kind < 0.5:
            blocks.append([("F", float(rng.randint(20, 900)))])
        elif kind < 0.65:
            blocks.append([("G", 91), ("G", rng.choice([0, 1])), (rng.choice("XYZ"), coord())])
            blocks.append([(rng.choice("XY"), coord())])
            blocks.append([("G", 90)])
        else:
            r = round(rng.uniform(-2, 10), 1)
            hole = [("G", rng.choice([98, 99])), ("G", 81), ("X", coord()), ("Y", coord()),
                    ("Z", round(r - rng.uniform(1, 15), 2)), ("R", r), ("F", float(rng.randint(20, 400)))]
            blocks.append(hole)
            for _ in range(rng.randint(0, 3)):
                blocks.append([(a, coord()) for a in rng.sample("XY", rng.randint(1, 2))])
            blocks.append([("G", 80)])            # alone: G80 and G0 are of one modal group
            blocks.append([("G", 0)] + ([("Z", round(rng.uniform(2, 20), 1))] if rng.random() < 0.5 else []))
    return blocks


def test_words_written_every_way(lab):
    """TODO 1: parse_words reads any case and spacing RS274NGC allows: spaces inside numbers, +, .5, 5., G01"""
    rng = cases("10 words")
    for _ in range(200):
        block = [(rng.choice("GXYZFRN"), round(rng.uniform(-99, 99), rng.choice([0, 1, 3]))) for _ in range(rng.randint(1, 6))]
        block = [(letter, abs(v) if letter in "GFN" else v) for letter, v in block]
        line = _render(rng, block)
        got = [(str(a).upper(), float(b)) for a, b in lab.parse_words(line)]
        want = [(a, float(v)) for a, v in words_here(line)]
        expect(got == want, f"parse_words({line!r}); {seed_note()}", expected=want, got=got,
               hint="RS274NGC ignores spaces and tabs, even inside a number: drop them first; lower case counts too; "
                    "a number may start with + or - or a point, and end with a point")


def test_programs_never_seen(lab):
    """TODO 4: interpret() on random programs of the lab's words, written in every case and spacing"""
    rng = cases("10 programs")
    for _ in range(25):
        text = "\n".join(_render(rng, block) for block in random_program(rng)) + "\n"
        want = interpret_here(text)
        got = [(m.kind, m.x, m.y, m.z, m.feed) for m in lab.interpret(text)]
        first = next((i for i, (g, w) in enumerate(zip(got, want)) if not _same([g], [w])), min(len(got), len(want)))
        expect(_same(got, want), f"the moves of this program; {seed_note()}:\n{text}",
               expected=f"{len(want)} moves; move {first + 1}: {want[first] if first < len(want) else 'none'}",
               got=f"{len(got)} moves; move {first + 1}: {got[first] if first < len(got) else 'none'}",
               hint="modal: G0/G1/G81, G90/G91, G98/G99 and F stay until changed; a block with only X/Y repeats the "
                    "cycle there; G80 ends it")


def test_interpreter_is_your_own(lab):
    """TODO 4: interpret() works the moves out itself, not with retrofit's G-code interpreter"""
    places = borrowed(target_path(Path(__file__).parent), {"retrofit.gcode": set()},
                      within={"parse_words", "target", "g81_moves", "interpret"})
    expect(not places, "where your interpret() gets its moves", expected="your own modal state",
           got="retrofit's interpreter: " + "; ".join(places), hint="the lab is to write the interpreter")


@pytest.mark.points(0)       # checks the checks, not the student
def test_the_checks_interpreter_agrees_with_linuxcnc():
    """The checks' own interpreter gives LinuxCNC's moves on the lab's programs (a check of the checks)"""
    for name in NAMES:
        text = (PROGRAMS / f"{name}.ngc").read_text(encoding="utf-8")
        expect(_same(interpret_here(text), recorded(name)), f"{name}: the checks' interpreter against LinuxCNC",
               expected=recorded(name), got=interpret_here(text))


@pytest.mark.points(0)       # checks the checks, not the student
def test_recorded_and_retrofit_agree_where_both_run():
    """The two oracles agree on the programs retrofit runs (a check of the checks)"""
    for name in NAMES:
        ours = by_retrofit(name)
        if ours is not None:
            expect(_same(ours, recorded(name)), f"{name}: retrofit against LinuxCNC",
                   expected=recorded(name), got=ours)
