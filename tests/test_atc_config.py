"""tul-mill's machine file: the document's machine, read strictly."""

import re
from importlib import resources

import pytest

from retrofit.atc.settings import atc_of, tools_of
from retrofit.errors import ConfigError
from retrofit.machine.config import load_machine

MILL = load_machine("tul-mill")
SOURCE = (resources.files("retrofit") / "machines" / "tul-mill.toml").read_text()


def test_the_documents_machine():
    assert MILL.port == "ramps"
    assert MILL.axis_names == ("X", "Y", "Z", "E")
    travel = {a.name: (a.min_mm, a.max_mm) for a in MILL.axes[:3]}
    assert travel == {"X": (0.0, 45.0), "Y": (0.0, 45.0), "Z": (-45.0, 0.0)}   # 45 x 45 x 45 mm, Z+ up
    for axis in MILL.axes:
        assert (axis.max_velocity_mm_s, axis.max_accel_mm_s2) == (50.0, 1000.0)
    pins = {a.name: (a.step_pin, a.dir_pin) for a in MILL.axes}
    assert pins == {"X": (54, 55), "Y": (60, 61), "Z": (46, 48), "E": (26, 28)}   # RAMPS 1.4
    ramps = MILL.parts["ramps"]
    assert ramps.enable_pins == {"X": 38, "Y": 56, "Z": 62, "E": 24}
    assert ramps.spindle_pwm_pin == 10
    assert MILL.parts["homing"].order[:3] == ("Z", "Y", "X")


def test_the_tool_changer_constants_and_feeds():
    atc = atc_of(MILL)
    assert (atc.x1, atc.y_point_a, atc.y_point_b) == (23.0, 28.0, 44.0)
    # the document measures Z downward from the top (Z_POINT_1 40.5, Z_POINT_2 45); here Z+ is up
    assert (atc.z_point_1, atc.z_point_2) == (-40.5, -45.0)
    assert (atc.atc_offset, atc.atc_home, atc.pockets, atc.axis) == (3.2, 0.0, 12, "E")
    assert (atc.feed_in_mm_min, atc.feed_out_mm_min, atc.feed_clamp_mm_min) == (800.0, 1000.0, 200.0)
    assert (atc.sim.first_pocket_deg, atc.sim.pocket_pitch_deg) == (80.0, 20.0)
    assert sorted(tools_of(MILL).sim) == list(range(1, 13))


def test_homing_z_goes_up_to_the_top_of_travel():
    ztop = MILL.parts["switches"].named("ztop")
    assert (ztop.axis, ztop.trip_mm, ztop.side) == ("Z", 0.0, 1)            # closed at Z >= 0
    assert MILL.axis("Z").max_mm == ztop.trip_mm


@pytest.mark.parametrize("setting", ["down", "up"])
def test_a_z_direction_setting_is_refused_saying_z_is_up(tmp_path, setting):
    path = variant(tmp_path, "[tools.sim]", f"[tools]\nz_positive = \"{setting}\"\n\n[tools.sim]")
    with pytest.raises(ConfigError, match="^" + re.escape(f"tul-mill.toml [tools] z_positive = '{setting}': "
                                                           "no such setting: Z+ is up on every machine")):
        load_machine(path)


def variant(tmp_path, old, new):
    assert old in SOURCE, old
    path = tmp_path / "tul-mill.toml"
    path.write_text(SOURCE.replace(old, new, 1))
    return path


@pytest.mark.parametrize("old, new, message", [
    ("atc_offset = 3.2", "atc_offset = 5.2",
     "tul-mill.toml [atc] atc_offset = 5.2: puts pocket 12 at 17.2, outside axis E 0..16"),
    ("x1 = 23.0", "x1 = 50.0", "tul-mill.toml [atc] x1 = 50.0: must lie within axis X 0..45"),
    ("pockets = 12", "pocketz = 12", "tul-mill.toml [atc] pocketz: unknown key (did you mean pockets?)"),
    ("change_on = \"T\"", "change_on = \"M7\"", "tul-mill.toml [atc] change_on = 'M7': must be one of M6, T"),
    ("magazine_y_mm = 36.0", "magazine_y_mm = 20.0",
     "tul-mill.toml [atc.sim] magazine_y_mm = 20.0: must lie between Y_POINT_A and Y_POINT_B (28..44)"),
    ("z_point_1 = -40.5", "z_point_1 = 40.5",
     "tul-mill.toml [atc] z_point_1 = 40.5: must lie within axis Z -45..0"),
    ("t12 = {", "x12 = {", "tul-mill.toml [tools.sim] x12: must be a tool number such as t1, t12"),
    ("spindle_pwm_pin = 10", "spindle_pwm_pin = 26",
     "tul-mill.toml [ramps] spindle_pwm_pin = 26: already used by E.step_pin"),
    ("beam_y_mm = 8.0", "beam_y_mm = 2.0", "tul-mill.toml [setter] max_diameter_mm = 8.0: puts the "
                                           "diameter approach at Y -4.25, outside 0..45"),
], ids=["pocket-beyond-travel", "x1-outside", "typo", "change-on", "zone", "z-counted-down",
        "tool-key", "pin-twice", "setter-approach"])
def test_mistakes_name_file_section_key_and_rule(tmp_path, old, new, message):
    with pytest.raises(ConfigError, match="^" + re.escape(message)):
        load_machine(variant(tmp_path, old, new))
