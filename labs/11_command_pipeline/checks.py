"""Checks of lab 11 (the command set and its pipeline): `retrofit lab check 11`, or pytest on this file.

Every check plays seeded random command streams on several machines -- shipped ones with a
small look-ahead, and random valid ones -- and compares your controller's whole state with the
model below after every command and every tick; a failure names the seed, the machine and the
event. The model is written here, from 002 and docs/controller.md, and nothing in it comes from
retrofit: your file cannot reach it. (tests/test_lab_11.py holds this model equal to
retrofit's controller, ``retrofit.controller.Controller``, on random streams.)
"""

import random
from dataclasses import replace

import pytest

from retrofit.machine.config import load_machine
from retrofit.lab.core import expect, load_target

KEYS = ("window", "queue", "prepared", "executing", "cycle", "position", "offset", "stopped", "error", "interp")
IMMEDIATE = ("RDPS", "RDST", "STOP", "INIT", "FFDR", "MFDR")


def _words(text):
    head, *rest = text.split()
    return head, [(w[0], float(w[1:])) for w in rest if len(w) > 1], [w for w in rest if len(w) == 1]


def _point(start, end, cycle):
    """Where 002's Bresenham is after ``cycle`` cycles: each axis at the lattice point nearest the
    line, ties towards the start in the first half, the end in the second, down at the middle."""
    n = max(abs(e - s) for s, e in zip(start, end))
    out = []
    for s, e in zip(start, end):
        d, sign = abs(e - s), (e > s) - (e < s)
        q = 2 * cycle * d + n
        steps = (q - 1) // (2 * n) if n else 0
        if n and q % (2 * n) == 0 and (2 * cycle > n or (2 * cycle == n and sign < 0)):
            steps += 1
        out.append(s + sign * steps)
    return out


class Model:
    """002's controller as the lab describes it (the checks' own, independent of your file)."""

    def __init__(self, machine):
        self.m = machine
        self.reset()

    def reset(self):
        n, motion = len(self.m.axes), self.m.motion
        self.window, self.queue, self.prepared, self.executing, self.cycle = motion.lookahead + 1, [], [], None, 0
        self.position, self.offset, self.stopped, self.error = [0] * n, [0] * n, False, False
        self.interp = {"position": [0] * n, "offset": [0] * n, "feed": motion.default_feed_mm_min,
                       "rapid": motion.rapid_feed_mm_min, "group": 0}

    def state(self):
        return _plain({k: getattr(self, k) for k in KEYS})

    def prepare(self, text):
        head, words, letters = _words(text)
        names, ip = self.m.axis_names, self.interp
        if head == "PFDR" and words[0][1] <= 0:
            return {"kind": "refused", "cmd": text}
        if head == "PFDR":
            ip["feed"], ip["group"] = words[0][1], ip["group"] + 1
        elif head == "DELY":
            return {"kind": "dwell", "cmd": text, "n": round(words[0][1] / self.m.tick_s)}
        elif head == "PSTN":
            for name, mm in words:
                i = names.index(name)
                ip["offset"][i] = ip["position"][i] - round(mm * self.m.axes[i].steps_per_mm)
            return {"kind": "pstn", "cmd": text, "offset": list(ip["offset"])}
        elif head in ("FMOV", "PMOV", "ZMOV"):
            end = list(ip["position"])
            for name, mm in words:
                i = names.index(name)
                end[i] = round(mm * self.m.axes[i].steps_per_mm) + ip["offset"][i]
            for name in (letters or names) if head == "ZMOV" else ():
                end[names.index(name)] = 0
            if any(not a.min_steps <= e <= a.max_steps for a, e in zip(self.m.axes, end)):
                return {"kind": "refused", "cmd": text}
            start, ip["position"] = ip["position"], end
            return {"kind": "move", "cmd": text, "start": list(start), "end": list(end),
                    "n": max(abs(a - b) for a, b in zip(start, end)), "feed": ip["feed" if head == "PMOV" else "rapid"],
                    "rapid": head != "PMOV", "group": ip["group"]}
        return None

    def halt(self, error):
        self.queue, self.prepared, self.executing, self.cycle = [], [], None, 0
        self.interp["position"], self.interp["offset"] = list(self.position), list(self.offset)
        self.error, self.stopped = self.error or error, self.stopped or not error

    def interpret(self):
        while self.queue and sum(e["kind"] != "pstn" for e in self.prepared) < self.window \
                and len(self.prepared) < self.window + 16:
            entry = self.prepare(self.queue.pop(0))
            if entry is not None and entry["kind"] == "refused":
                return self.halt(True)
            if entry is not None:
                self.prepared.append(entry)

    def submit(self, text):
        head, words, _ = _words(text)
        if head == "RDPS":
            return [p - o for p, o in zip(self.position, self.offset)]
        if head == "RDST":
            kind = self.executing["kind"] if self.executing else ""
            return {"queued": len(self.queue), "queue_full": len(self.queue) >= 3, "moving": kind == "move",
                    "dwelling": kind == "dwell", "stopped": self.stopped, "error": self.error}
        if head in ("STOP", "INIT"):
            return self.halt(False) if head == "STOP" else self.reset()
        if head in ("FFDR", "MFDR"):
            return self.override(head, words[0][1]) if words[0][1] > 0 else "ERR"
        if self.stopped or self.error:
            return "ERR"
        if len(self.queue) == 3:
            return "BUSY"
        self.queue.append(text)
        self.interpret()
        return "ERR" if self.error else None

    def override(self, head, feed):
        moves = [e for e in [self.executing] + self.prepared if e and e["kind"] == "move"]
        if head == "FFDR":
            self.interp["rapid"] = feed
            hit = [e for e in moves if e["rapid"]]
        else:
            group = next((e["group"] for e in moves if not e["rapid"]), self.interp["group"])
            if group == self.interp["group"]:
                self.interp["feed"] = feed
            hit = [e for e in moves if not e["rapid"] and e["group"] == group]
        for e in hit:
            e["feed"] = feed

    def tick(self):
        if self.stopped or self.error:
            return
        if self.executing is not None:
            self.cycle += 1
            if self.executing["kind"] == "move":
                self.position = _point(self.executing["start"], self.executing["end"], self.cycle)
            if self.cycle < self.executing["n"]:
                return self.interpret()
            self.executing, self.cycle = None, 0
        while self.prepared and self.executing is None:
            entry = self.prepared.pop(0)
            if entry["kind"] == "pstn":
                self.offset = list(entry["offset"])
                continue
            self.executing, self.cycle = entry, 0
            self.interpret()
            if self.executing is not None and entry["n"] == 0:
                self.executing = None           # a null move or a zero dwell ends as it starts
        self.interpret()

    def play(self, events):
        records = []
        for kind, value in events:
            if kind == "submit":
                records.append((_reply(self.submit(value)), self.state()))
            else:
                for _ in range(value):
                    self.tick()
                    records.append((None, self.state()))
        return records


def _reply(reply):
    return _plain("OK" if reply is None else reply)


#: the keys the handout asks for; others a student keeps for their own use are not compared
FIELDS = {"move": ("kind", "cmd", "start", "end", "n", "feed", "rapid", "group"), "dwell": ("kind", "cmd", "n"),
          "pstn": ("kind", "cmd", "offset"), "refused": ("kind", "cmd"),
          "interp": ("position", "offset", "feed", "rapid", "group"),
          "status": ("queued", "queue_full", "moving", "dwelling", "stopped", "error")}


def _plain(value):
    """Tuples as lists, numbers as int / float, dicts key by key (entries, the interpreter and RDST's
    answer by the keys the handout names): what a comparison should see."""
    kind = type(value)
    if kind is int or kind is str or kind is bool or value is None:
        return value
    if kind is dict:
        name = value.get("kind") if value.get("kind") in FIELDS else \
            "interp" if "rapid" in value and "kind" not in value else "status" if "queue_full" in value else None
        keys = FIELDS[name] if name else value
        return {k: _plain(value[k]) if k in value else "(missing)" for k in keys}
    if kind is list or kind is tuple:
        return [_plain(v) for v in value]
    if isinstance(value, bool):
        return bool(value)
    return float(value) if not float(value).is_integer() else int(value)


# -- machines and streams -------------------------------------------------------------------------
def _shipped(name, lookahead):
    machine = load_machine(name)
    return replace(machine, motion=replace(machine.motion, lookahead=lookahead))


def _random_machine(seed):
    """A valid machine nobody ships: odd steps/mm, other limits, feeds and look-ahead."""
    rng = random.Random(seed)
    base = load_machine(rng.choice(["chivu-lathe", "engraver"]))
    axes = tuple(replace(a, steps_per_mm=round(rng.uniform(20, 130), 3), min_mm=-round(rng.uniform(2, 9), 2),
                         max_mm=round(rng.uniform(2, 9), 2)) for a in base.axes)
    motion = replace(base.motion, lookahead=rng.randint(1, 4), default_feed_mm_min=float(rng.randint(50, 500)),
                     rapid_feed_mm_min=float(rng.randint(800, 3000)))
    return replace(base, name=f"random-{seed}", axes=axes, motion=motion)


MACHINES = {"mitic-lathe": lambda: _shipped("mitic-lathe", 1), "chivu-lathe": lambda: _shipped("chivu-lathe", 2),
            "tul-mill": lambda: _shipped("tul-mill", 1), "random-7": lambda: _random_machine(7),
            "random-31": lambda: _random_machine(31)}


def _command(rng, machine, queued_only=False):
    names = machine.axis_names

    def axes(word="", limit=True):
        picked = [n for n in names if rng.random() < 0.6] or [rng.choice(names)]
        out = []
        for name in picked:
            a = machine.axis(name)
            span = min(250 / a.steps_per_mm, 4.0)
            lo, hi = max(a.min_mm, -span), min(a.max_mm, span)
            mm = hi + rng.uniform(0.5, 3) if limit and rng.random() < 0.02 else rng.uniform(lo, hi)
            out.append(f"{name}{round(mm, rng.choice([0, 1, 2, 3])):g}")
        return " ".join(out)
    table = [("PMOV ", 28, axes), ("FMOV ", 14, axes),
             ("PFDR F", 7, lambda: f"{rng.choice([120, 250.5, 640, 640, 640, 0])}"),
             ("DELY P", 5, lambda: f"{rng.choice([0, 1, 3, 40, 250]) * machine.tick_s:.6g}"),
             ("PSTN ", 5, lambda: axes(limit=False)),
             ("CSTP", 3, str), ("ZMOV", 0 if "homing" in machine.parts else 3,
                                 lambda: rng.choice(["", " " + rng.choice(names)]))]
    if not queued_only:
        table += [("RDST", 6, str), ("RDPS", 6, str), ("MFDR F", 5, lambda: f"{rng.choice([60, 400, 900.5, 0])}"),
                  ("FFDR F", 4, lambda: f"{rng.choice([500, 2000])}"), ("STOP", 1, str), ("INIT", 2, str)]
    head, _, tail = rng.choices(table, weights=[w for _, w, _ in table])[0]
    return (head + tail()).strip()


def _stream(seed, machine, commands=40):
    """Commands at random moments; once halted, an INIT comes back after a command or two."""
    rng, model, events, halted = random.Random(seed), Model(machine), [], 0
    for _ in range(commands):
        halted = halted + 1 if model.stopped or model.error else 0
        text = "INIT" if halted > rng.randint(1, 3) else _command(rng, machine)
        events.append(("submit", text))
        model.submit(text)
        if rng.random() < 0.45:
            events.append(("tick", rng.choice([1, 1, 2, 5, rng.randint(5, 400)])))
            for _ in range(events[-1][1]):
                model.tick()
    return events + [("tick", 600)]


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


HINTS = {"queue": "commands wait in the queue only while the window is full; three at most",
         "prepared": "prepare a command as soon as the window has room: fewer than `window` moves and "
                     "dwells in it (a PSTN rides along)",
         "executing": "the next entry starts on the tick the last cycle of the one before runs; a null move "
                      "or a zero dwell ends as it starts",
         "cycle": "the first cycle runs the tick after an entry starts",
         "position": "one Bresenham cycle a tick: point_at(start, end, cycle)",
         "offset": "a PSTN's offset takes effect when the processor reaches its entry",
         "interp": "the interpreter's state after preparing: position and offset in machine steps, feed, "
                   "rapid, group (PFDR count)",
         "stopped": "STOP halts; queued commands are refused (ERR) until INIT", "error": "a refused entry halts"}


def compare(what, seed, machine, events, want, got):
    """The first record that differs, worded for a student."""
    expect(len(got) == len(want), f"{what}: records (one per command and per tick)", expected=len(want),
           got=len(got))
    for k, ((reply, state), (my_reply, mine)) in enumerate(zip(want, got)):
        mine = _plain(mine)
        at = (f"{what} on {machine.name} (seed {seed}), after record {k}: "
              + (f"submit {events[k]!r}" if isinstance(events[k], str) else "a tick"))
        mine_reply = _reply(my_reply) if isinstance(events[k], str) else _plain(my_reply)   # None is "OK" too
        expect(mine_reply == reply, at + ": the reply", expected=reply, got=my_reply,
               hint="immediate commands (RDPS, RDST, STOP, INIT, FFDR, MFDR) answer even when the queue is full; "
                    "BUSY when three wait; ERR after STOP or an error until INIT")
        for key in KEYS:
            expect(mine.get(key) == state[key], f"{at}: {key}", expected=state[key], got=mine.get(key),
                   hint=HINTS.get(key, ""))


def _flat(events):
    return [e for kind, value in events for e in ([value] if kind == "submit" else [None] * value)]


# -- TODO 1: prepare ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(MACHINES))
def test_prepare(lab, name):
    """TODO 1: prepare turns each queued command into its entry and keeps the interpreter's state"""
    machine = MACHINES[name]()
    for seed in (101, 102, 103):
        rng, model = random.Random(seed), Model(machine)
        interp = lab.new_interpreter(machine)
        expect(_plain(interp) == model.interp, f"new_interpreter({name})", expected=model.interp, got=interp)
        for k in range(40):
            text = _command(rng, machine, queued_only=True)
            entry = model.prepare(text)
            interp, mine = lab.prepare(interp, machine, text)
            if entry is not None and entry["kind"] == "refused":
                expect(mine is not None and mine.get("kind") == "refused",
                       f"prepare({text!r}) on {name} (seed {seed})", got=mine,
                       expected="an entry of kind 'refused' (a target outside the soft limits, or a feed not above 0)")
                break
            expect(_plain(mine) == _plain(entry), f"prepare(interp, {name}, {text!r}), command {k} of seed {seed}",
                   expected=entry, got=mine, hint="targets: round(mm x steps/mm) + the PSTN offset; FMOV and ZMOV "
                   "at the rapid feed, PMOV at the program feed (PFDR, counted in group); n = steps of the "
                   "longest axis")
            expect(_plain(interp) == model.interp, f"the interpreter after prepare({text!r}) on {name} (seed {seed})",
                   expected=model.interp, got=interp, hint=HINTS["interp"])


# -- TODO 2: interpret -------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(MACHINES))
def test_interpret_fills_the_window(lab, name):
    """TODO 2: interpret prepares from the queue while the window has room, and halts on a refused entry"""
    machine = MACHINES[name]()
    for seed in range(201, 216):
        rng, model = random.Random(seed), Model(machine)
        model.queue = [_command(rng, machine, queued_only=True) for _ in range(rng.randint(1, 3))]
        model.prepared = [e for e in (model.prepare(_command(rng, machine, True)) for _ in range(rng.randint(0, 5)))
                          if e and e["kind"] != "refused"]
        if seed == 215:                    # a window of PSTNs: they ride along, 16 at most
            model.prepared = [model.prepare("PSTN X1") for _ in range(model.window + 15)]
            model.queue = ["PSTN X2", "PMOV X0"]
        before = model.state()
        model.interpret()
        mine = _plain(lab.interpret(before, machine))
        for key in KEYS:
            expect(mine.get(key) == model.state()[key], f"interpret(state) on {name} (seed {seed}): {key}; queue was "
                   f"{before['queue']}, {len(before['prepared'])} entries prepared, window {before['window']}",
                   expected=model.state()[key], got=mine.get(key), hint=HINTS.get(key, ""))


# -- TODO 3: submit ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(MACHINES))
def test_submit_scans_for_immediate_commands(lab, name):
    """TODO 3: submit answers immediate commands at once, queues three, says BUSY, refuses after STOP"""
    machine = MACHINES[name]()
    for seed in range(301, 306):
        rng, model = random.Random(seed), Model(machine)
        events = [_command(rng, machine) for _ in range(30)]
        want = [(_reply(model.submit(text)), model.state()) for text in events]
        got = lab.run(machine, [("submit", text) for text in events])
        compare("submit, nothing executing", seed, machine, events, want, got)


# -- TODO 4: tick --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(MACHINES))
def test_tick_executes_one_cycle_at_a_time(lab, name):
    """TODO 4: tick runs one cycle of the entry executing, starts the next on the same tick, refills the window"""
    machine = MACHINES[name]()
    for seed in range(401, 404):
        rng, model = random.Random(seed), Model(machine)
        for _ in range(rng.randint(4, 9)):
            if len(model.queue) < 3:
                model.queue.append(_command(rng, machine, queued_only=True))
                model.interpret()
        if seed == 403:                    # zero dwells ahead of a queued move: all start and end in one tick
            model.reset()
            model.prepared = [model.prepare("DELY P0") for _ in range(model.window)]
            model.queue = ["FMOV " + " ".join(f"{n}0" for n in machine.axis_names)]
        state, want = model.state(), []
        while (model.executing or model.prepared or model.queue) and len(want) < 3000:
            model.tick()
            want.append((None, model.state()))
        events = [None] * len(want)
        got = [(None, s) for s in lab.run_ticks(state, machine, len(want))]
        compare("tick after tick", seed, machine, events, want, got)


# -- TODOs 1-4: the whole controller on random streams ------------------------------------------------------
@pytest.mark.parametrize("name", list(MACHINES))
def test_random_streams(lab, name):
    """TODOs 1-4: your controller equals 002's on random command streams, after every command and tick"""
    machine = MACHINES[name]()
    for seed in (501, 502):
        events = _stream(seed, machine)
        compare("random stream", seed, machine, _flat(events), Model(machine).play(events), lab.run(machine, events))
