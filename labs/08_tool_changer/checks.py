"""Checks of lab 08 (the tool changer): run with `retrofit lab check 08`, or pytest on this file.

Besides the lab's T3 -> T7 change, the checks draw cases at random (seeded: RETROFIT_CHECK_SEED draws
them again): other discs (pocket angles, pitch, station, degrees per unit that are not whole), a
change between other tools from a start where the carousel is not at 0, samples at irregular
times, and traces where the carousel starts anywhere. The expected values are worked here.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from retrofit.atc.cell import SimCell
from retrofit.atc.magazine import MagazineState
from retrofit.atc.sequences import change_sequence
from retrofit.atc.settings import atc_of
from retrofit.machine.config import load_machine
from retrofit.lab.check import borrowed, cases, seed_note
from retrofit.lab.core import expect, load_target, target_path

START_MM = {"X": 5.0, "Y": 5.0, "Z": -5.0, "E": 0.0}


@pytest.fixture(scope="module")
def lab():
    """The file under check: student.py, or what RETROFIT_LAB_TARGET names."""
    return load_target(__file__)


@pytest.fixture(scope="module")
def mill():
    return load_machine("tul-mill")


@pytest.fixture(scope="module")
def atc(mill):
    return atc_of(mill)


@pytest.fixture(scope="module")
def cell(mill, atc):
    """The T3 -> T7 change run by the checks themselves, from X5 Y5 Z-5 with the carousel at home."""
    cell = SimCell(mill, MagazineState.loaded(mill, 3), start_mm=START_MM)
    cell.run(change_sequence(atc, 3, 7, mill.name).commands())
    return cell


@pytest.fixture(scope="module")
def other_change(mill, atc):
    """A change between two other tools, run by the checks from a random start, the carousel not at 0:
    (cell, start, from tool, to tool)."""
    rng = cases("08 other change")
    current, new = rng.sample(range(1, 13), 2)
    start = {"X": round(rng.uniform(-20, 60), 2), "Y": round(rng.uniform(-10, 30), 2), "Z": round(rng.uniform(-20, 0), 2),
             "E": float(rng.randint(1, 11))}
    cell = SimCell(mill, MagazineState.loaded(mill, current), start_mm=start)
    cell.run(change_sequence(atc, current, new, mill.name).commands())
    return cell, start, current, new


def random_disc(rng, base):
    return replace(base, first_pocket_deg=round(rng.uniform(0.0, 120.0), rng.choice([0, 2])),
                   pocket_pitch_deg=round(rng.uniform(10.0, 45.0), rng.choice([0, 3])),
                   station_deg=round(rng.uniform(-60.0, 60.0), 2), degrees_per_unit=round(rng.uniform(5.0, 40.0), 3))


def test_pocket_and_carousel_on_random_discs(lab, atc):
    """TODO 1, 2: pocket angles and carousel positions on random discs: nothing of the tul-mill's written in"""
    rng = cases("08 discs")
    for _ in range(20):
        disc, pocket = random_disc(rng, atc.sim), rng.randint(1, 14)
        angle = disc.first_pocket_deg + (pocket - 1) * disc.pocket_pitch_deg
        got = float(lab.pocket_angle_deg(disc, pocket))
        expect(abs(got - angle) < 1e-9, f"pocket_angle_deg({disc}, {pocket}); {seed_note()}", expected=f"{angle:g}",
               got=f"{got:g}", hint="first_pocket_deg for pocket 1, then pocket_pitch_deg more for each next pocket")
        want = (angle + disc.station_deg) / disc.degrees_per_unit
        got = float(lab.carousel_position(disc, pocket))
        expect(abs(got - want) < 1e-9, f"carousel_position({disc}, {pocket}); {seed_note()}", expected=f"{want:.6g}",
               got=f"{got:.6g}", hint="(the pocket's angle + station_deg) / degrees_per_unit, all from the disc given")


def test_carousel_position_is_your_own(lab):
    """TODO 2: carousel_position works the position out from the disc, not with the tool changer's own"""
    places = borrowed(target_path(Path(__file__).parent), {"retrofit.atc.settings": {"atc_of"}},
                      within={"carousel_position", "pocket_angle_deg"}, methods=frozenset({"pocket_position"}))
    expect(not places, "how your carousel_position gets the position", expected="from the disc you are given",
           got="the tool changer's own: " + "; ".join(places), hint="the lab is to work it out from the disc's angles")


def test_pocket_angles(lab, atc):
    """TODO 1: pocket n sits at 80 + 20 (n - 1) degrees on the disc"""
    got = [float(lab.pocket_angle_deg(atc.sim, n)) for n in range(1, 13)]
    want = [80.0 + 20.0 * (n - 1) for n in range(1, 13)]
    expect(np.allclose(got, want), "pocket_angle_deg(atc.sim, n) for pockets 1..12", expected=want, got=got,
           hint="first_pocket_deg for pocket 1, then pocket_pitch_deg more for each next pocket")
    other = replace(atc.sim, first_pocket_deg=90.0, pocket_pitch_deg=30.0)
    got = float(lab.pocket_angle_deg(other, 4))
    expect(abs(got - 180.0) < 1e-9, "pocket_angle_deg of pocket 4 on a disc with pocket 1 at 90°, every 30°",
           expected="180.0", got=f"{got:g}", hint="read the angles from the geometry you are given, not 80 and 20")


def test_carousel_positions(lab, atc):
    """TODO 2: the carousel position of pocket n is the machine's ATC_OFFSET + n (3.2 + n)"""
    got = [float(lab.carousel_position(atc.sim, n)) for n in range(1, 13)]
    want = [(80.0 + 20.0 * (n - 1) + atc.sim.station_deg) / atc.sim.degrees_per_unit for n in range(1, 13)]
    expect(np.allclose(got, want, atol=1e-9), "carousel_position(atc.sim, n) for pockets 1..12",
           expected=[round(w, 3) for w in want], got=[round(g, 3) for g in got],
           hint="the disc turns by the pocket's angle plus station_deg; one carousel unit is degrees_per_unit "
                "degrees")
    other = replace(atc.sim, first_pocket_deg=90.0, pocket_pitch_deg=30.0, station_deg=-45.0, degrees_per_unit=15.0)
    got = float(lab.carousel_position(other, 4))
    expect(abs(got - 9.0) < 1e-9, "carousel_position of pocket 4 on a disc with pocket 1 at 90°, every 30°, the "
           "station at -45° and 15° a unit", expected="9.0 = (180 - 45) / 15", got=f"{got:g}",
           hint="read station_deg and degrees_per_unit from the geometry you are given")


def test_over_time(lab, mill, atc, cell):
    """TODO 3: over_time gives seconds and mm from the start, the carousel in degrees"""
    for name in ("X", "Z", "E"):
        trace = cell.sim.traces[name]
        scale = atc.sim.degrees_per_unit if name == "E" else 1.0
        want_t = np.concatenate([[0.0], np.asarray(trace.ticks) * mill.tick_s])
        want_v = np.concatenate([[START_MM[name]], np.asarray(trace.carriage_mm)]) * scale
        t, v = (np.asarray(a, float) for a in lab.over_time(cell, name, START_MM[name]))
        expect(t.shape == want_t.shape and v.shape == want_v.shape,
               f"over_time(cell, {name!r}, {START_MM[name]:g}): how many samples",
               expected=f"{len(want_t)}: the start, then one after each of the {len(trace.ticks)} steps",
               got=f"{len(t)} times, {len(v)} positions", hint="put (0.0, start) in front of the trace")
        expect(np.allclose(t, want_t), f"over_time(cell, {name!r}, ...): the times",
               expected=f"seconds, from 0 to {want_t[-1]:.4f}", got=f"from {t[0]:g} to {t[-1]:g}",
               hint="ticks times cell.machine.tick_s")
        unit = "degrees (units x degrees_per_unit)" if name == "E" else "mm (the carriage)"
        expect(np.allclose(v, want_v), f"over_time(cell, {name!r}, ...): the positions",
               expected=f"{unit}, from {want_v[0]:g} up to {want_v.max():g}",
               got=f"from {v[0]:g} up to {v.max():g}", hint="trace.carriage_mm, not the motor steps; the "
                                                             "carousel in degrees")


def test_position_at(lab):
    """TODO 4: position_at looks up the last value at or before a time"""
    t, v = np.array([0.0, 1.0, 2.0, 3.0]), np.array([5.0, 6.0, 7.0, 8.0])
    for when, want in ((0.0, 5.0), (0.5, 5.0), (1.0, 6.0), (2.9, 7.0), (10.0, 8.0)):
        got = float(lab.position_at(t, v, when))
        expect(got == want, f"position_at([0, 1, 2, 3], [5, 6, 7, 8], {when:g})", expected=want, got=got,
               hint="np.searchsorted(t_s, t, side='right') - 1 is the index of the last sample at or before t")
    got = np.asarray(lab.position_at(t, v, np.array([0.2, 2.0, 3.5])), float)
    expect(got.tolist() == [5.0, 7.0, 8.0], "position_at with an array of times [0.2, 2.0, 3.5]",
           expected=[5.0, 7.0, 8.0], got=got.tolist(), hint="np.searchsorted takes an array of times too")


def test_over_time_other_change(lab, mill, atc, other_change):
    """TODO 3: over_time on another change, from a random start with the carousel not at 0"""
    cell, start, current, new = other_change
    for name in ("X", "Y", "Z", "E"):
        trace = cell.sim.traces[name]
        scale = atc.sim.degrees_per_unit if name == "E" else 1.0
        want_t = np.concatenate([[0.0], np.asarray(trace.ticks) * mill.tick_s])
        want_v = np.concatenate([[start[name]], np.asarray(trace.carriage_mm)]) * scale
        t, v = (np.asarray(a, float) for a in lab.over_time(cell, name, start[name]))
        ok = t.shape == want_t.shape and v.shape == want_v.shape and np.allclose(t, want_t) and np.allclose(v, want_v)
        expect(ok, f"over_time(cell, {name!r}, {start[name]:g}) on the T{current} -> T{new} change from {start}; "
                   f"{seed_note()}", expected=f"{len(want_t)} samples, positions from {want_v[0]:g} to {want_v[-1]:g}",
               got=f"{len(t)} samples, positions from {v[0] if len(v) else '-'} to {v[-1] if len(v) else '-'}",
               hint="(0.0, start) first, then the trace; the carousel in degrees, its start too")


def test_position_at_irregular_samples(lab):
    """TODO 4: position_at on samples at irregular times that need not start at 0"""
    rng = cases("08 position at")
    for _ in range(25):
        t = np.cumsum([rng.uniform(0.0, 2.0)] + [rng.uniform(0.001, 0.8) for _ in range(rng.randint(1, 30))])
        v = np.array([round(rng.uniform(-50, 50), 3) for _ in t])
        when = np.array([rng.choice([rng.uniform(t[0], t[-1] + 1.0), float(rng.choice(t))]) for _ in range(8)])
        want = np.array([v[max(k for k in range(len(t)) if t[k] <= w)] for w in when])
        got = np.asarray(lab.position_at(t, v, when), float)
        expect(got.shape == want.shape and np.array_equal(got, want), f"position_at(t_s {np.round(t, 4).tolist()}, "
               f"values {v.tolist()}, {np.round(when, 4).tolist()}); {seed_note()}"[:1000],
               expected=want.tolist(), got=got.tolist(),
               hint="the last sample at or before each time, whatever the spacing of the samples")


def unsafe_reference(traces, atc):
    """Carousel steps (every sample of E but its first) with Y beyond the magazine and Z below Z_POINT_1."""
    def at(name, when):
        t, v = traces[name]
        return v[max(k for k in range(len(t)) if t[k] <= when)]
    t_e = traces["E"][0]
    return [float(w) for w in t_e[1:]
            if at("Y", w) > atc.sim.magazine_y_mm and at("Z", w) < atc.z_point_1 - 1e-6]


def test_unsafe_turns_random_traces(lab, atc):
    """TODO 5: unsafe_turns on random traces: the carousel starting anywhere, the spindle in and out of the zone"""
    rng = cases("08 unsafe")
    for _ in range(25):
        def trace(low, high, count, edge):
            t = np.cumsum([0.0] + [rng.uniform(0.05, 1.0) for _ in range(count)])
            return t, np.array([edge if rng.random() < 0.15 else round(rng.uniform(low, high), 2) for _ in t])
        e_t = np.cumsum([0.0] + [rng.uniform(0.05, 0.6) for _ in range(rng.randint(1, 15))])
        first = rng.choice([0.0, round(rng.uniform(-180.0, 360.0), 1)])
        e_v = first + np.cumsum([0.0] + [rng.choice([-20.0, 20.0]) for _ in e_t[1:]])
        traces = {"X": (np.array([0.0]), np.array([23.0])),
                  "Y": trace(20.0, 50.0, rng.randint(0, 8), atc.sim.magazine_y_mm),
                  "Z": trace(-50.0, -30.0, rng.randint(0, 8), atc.z_point_1), "E": (e_t, e_v)}
        want = unsafe_reference(traces, atc)
        got = [float(t) for t in lab.unsafe_turns(traces, atc)]
        expect(np.allclose(got, want) if len(got) == len(want) else False,
               f"unsafe_turns with the carousel from {first:g}° stepping at {np.round(e_t[1:], 3).tolist()} s, Y "
               f"{traces['Y'][1].tolist()}, Z {traces['Z'][1].tolist()}; {seed_note()}"[:1000],
               expected=[round(w, 4) for w in want], got=[round(g, 4) for g in got],
               hint="every sample of E but the first is a step (the first is where it starts, at any angle); "
                    "unsafe: Y beyond magazine_y_mm and Z below Z_POINT_1 at that time")


def test_unsafe_turns(lab, atc):
    """TODO 5: unsafe_turns flags a carousel step only with the spindle down inside the magazine"""
    traces = {"X": (np.array([0.0]), np.array([23.0])),
              "Y": (np.array([0.0, 1.0, 3.0]), np.array([28.0, 44.0, 28.0])),
              "Z": (np.array([0.0, 2.0]), np.array([-45.0, -40.5])),
              "E": (np.array([0.0, 0.5, 1.5, 2.5, 3.5]), np.array([0.0, 20.0, 40.0, 60.0, 80.0]))}
    start_inside = dict(traces, Y=(np.array([0.0]), np.array([44.0])),
                        Z=(np.array([0.0, 1.0]), np.array([-45.0, -40.0])))
    got = [round(float(t), 6) for t in lab.unsafe_turns(start_inside, atc)]
    expect(got == [0.5], "unsafe_turns with the spindle down at Y 44 from the start, raised at 1 s: the carousel "
           "at 0 s (its start), steps at 0.5, 1.5, 2.5 and 3.5 s", expected=[0.5], got=got,
           hint="the first sample of E is where the carousel starts, not a step: leave it out")
    edge = dict(traces, Y=(np.array([0.0]), np.array([atc.sim.magazine_y_mm])), Z=(np.array([0.0]), np.array([-45.0])))
    got = [round(float(t), 6) for t in lab.unsafe_turns(edge, atc)]
    expect(got == [], f"unsafe_turns with the spindle down (Z -45) at Y {atc.sim.magazine_y_mm:g}, the edge of the "
           "magazine zone", expected=[], got=got, hint="inside the magazine is Y beyond atc.sim.magazine_y_mm; "
                                                  "exactly at it is outside")
    got = [round(float(t), 6) for t in lab.unsafe_turns(traces, atc)]
    expect(got == [1.5], "unsafe_turns: carousel steps at 0.5 s (Y 28, outside), 1.5 s (Y 44, Z -45), "
           "2.5 s (Y 44, Z -40.5) and 3.5 s (Y 28)", expected=[1.5], got=got,
           hint="unsafe = Y beyond atc.sim.magazine_y_mm and Z below Z_POINT_1, i.e. Z < atc.z_point_1 (Z+ is "
                "up); Z exactly at Z_POINT_1 is safe; the first sample of E is the start, not a step")


def test_carousel_turns_only_with_the_spindle_clear(lab, atc, cell):
    """Your whole analysis: in the T3 -> T7 change the carousel reaches pockets 3 and 7 and turns only when safe"""
    traces = {name: lab.over_time(cell, name, START_MM[name]) for name in ("X", "Y", "Z", "E")}
    degrees = set(np.round(np.asarray(traces["E"][1], float), 6).tolist())
    for pocket in (3, 7):
        angle = round(float(lab.carousel_position(atc.sim, pocket)) * atc.sim.degrees_per_unit, 6)
        expect(angle in degrees, f"the carousel reaches pocket {pocket}", expected=f"{angle:g}° among its positions",
               got=f"up to {max(degrees, default=0.0):g}°",
               hint="the carousel in degrees: its units times degrees_per_unit")
    unsafe = lab.unsafe_turns(traces, atc)
    expect(unsafe == [], "carousel steps with the spindle down in the magazine zone",
           expected="none: outside the zone (Y <= 36) or at the safe height (Z >= Z_POINT_1 -40.5)",
           got=f"{len(unsafe)}, the first at {unsafe[0]:.3f} s" if unsafe else "none",
           hint="look the spindle's Y and Z up at the time of each carousel step, with position_at")


def test_change_ends_with_t7_in_the_spindle(lab, atc, cell):
    """Your whole analysis: the change ends with T7 in the spindle, T3 in pocket 3, the axes at the magazine"""
    state = cell.magazine.state
    expect(state.spindle == 7 and state.pockets[3] == 3 and state.pockets[7] is None,
           "what the simulated magazine holds after the change", expected="T7 in the spindle, T3 in pocket 3, "
           "pocket 7 empty", got=f"T{state.spindle} in the spindle, pocket 3: {state.pockets[3]}, "
           f"pocket 7: {state.pockets[7]}")
    ends = {name: float(lab.over_time(cell, name, START_MM[name])[1][-1]) for name in ("X", "Y", "Z", "E")}
    want = {"X": atc.x1, "Y": atc.y_point_a, "Z": atc.z_point_2, "E": 0.0}
    expect(all(abs(ends[n] - want[n]) < 1e-6 for n in want), "where your traces end",
           expected="X1 23, Y_POINT_A 28, Z_POINT_2 -45 with T7, the carousel home at 0°",
           got=", ".join(f"{n} {v:g}" for n, v in ends.items()), hint="the last sample of each trace")
