"""The tool in the spindle survives a power cycle; a record that cannot be trusted says how to recover."""

import json
import os

import pytest

from retrofit.atc.cell import SimCell
from retrofit.atc.changer import ToolChanger
from retrofit.atc.sequences import homing_steps
from retrofit.atc.settings import atc_of
from retrofit.atc.state import SpindleStore
from retrofit.errors import ToolChangeError, ToolStateError
from retrofit.machine.config import load_machine

MILL = load_machine("tul-mill")
ATC = atc_of(MILL)


@pytest.fixture
def record(tmp_path):
    return tmp_path / "tul-mill-spindle.json"


def test_after_a_power_cycle_the_controller_knows_the_tool_in_the_spindle(record):
    changer, cell = ToolChanger(MILL, SpindleStore("tul-mill", record)), SimCell(MILL)
    changer.change(3, cell)
    machine_now, where = cell.magazine.state.copy(), cell.carriage_mm()
    del changer                                                   # power off: the controller forgets

    changer = ToolChanger(MILL, SpindleStore("tul-mill", record))  # power on
    assert changer.spindle_tool == 3
    cell = SimCell(MILL, machine_now, start_mm=where)              # the machine kept its tools and place
    cell.run([c for s in homing_steps(ATC, MILL.parts["homing"].order) for c in s.commands])
    seq = changer.change(5, cell)
    assert seq.condition == 2                                     # T3 goes back first
    assert cell.magazine.state.spindle == 5 and cell.magazine.state.pockets[3] == 3
    assert cell.violations == []
    assert ToolChanger(MILL, SpindleStore("tul-mill", record)).spindle_tool == 5


def test_a_machine_that_never_changed_a_tool_has_an_empty_spindle(record):
    assert SpindleStore("tul-mill", record).load() == 0


@pytest.mark.parametrize("content, why", [
    ("{\"machine\": \"tul-mill\", \"spindle_", "unreadable (JSONDecodeError"),
    ("", "unreadable (JSONDecodeError"),
    ("\x00\x01\x02", "unreadable"),
    ("[3]", "unreadable"),
    ("{\"machine\": \"tul-mill\"}", "unreadable (KeyError"),
    ("{\"machine\": \"tul-mill\", \"spindle_tool\": \"three\"}", "spindle_tool = 'three' is not a tool number"),
    ("{\"machine\": \"tul-mill\", \"spindle_tool\": -2}", "spindle_tool = -2 is not a tool number"),
    ("{\"machine\": \"grenoble-mill\", \"spindle_tool\": 2}", "belongs to machine 'grenoble-mill'"),
], ids=["truncated", "empty", "binary", "list", "no-tool", "text", "negative", "other-machine"])
def test_a_corrupt_record_gives_the_documented_error(record, content, why):
    record.write_text(content)
    with pytest.raises(ToolStateError) as err:
        ToolChanger(MILL, SpindleStore("tul-mill", record))
    message = str(err.value)
    assert message.startswith(f"{record}: the record of the tool in the spindle cannot be trusted: ")
    assert why in message
    assert message.endswith("Recovery: look at the spindle, then, to rewrite the record, home the "
                            "carousel and put that tool back into its pocket (T0), run this with n the "
                            "tool you see there (T0 if it is empty): retrofit tool T<n> --recover "
                            "--machine tul-mill")


def test_a_change_cut_short_is_known_at_the_next_start(record):
    class PowerCut:
        def run(self, commands):
            raise KeyboardInterrupt          # the power goes in the middle of the moves

        def commanded_mm(self):
            return {}

    changer = ToolChanger(MILL, SpindleStore("tul-mill", record))
    with pytest.raises(KeyboardInterrupt):
        changer.change(4, PowerCut())
    with pytest.raises(ToolStateError, match="the change from T0 to T4 was cut short"):
        ToolChanger(MILL, SpindleStore("tul-mill", record))


def test_recovery_homes_the_carousel_and_puts_the_seen_tool_back(record):
    from retrofit.atc.magazine import MagazineState
    record.write_text("garbage")
    changer = ToolChanger(MILL, SpindleStore("tul-mill", record), read_record=False)
    with pytest.raises(ToolChangeError, match="not known"):
        changer.sequence(2)
    cell = SimCell(MILL, MagazineState.loaded(MILL, 6), start_mm={"E": 3.0})   # T6 seen in the spindle
    steps = changer.recover(6, cell)
    assert str(steps[0].commands[0]) == "ZMOV E"
    assert cell.magazine.state.spindle is None and cell.magazine.state.pockets[6] == 6
    assert cell.violations == []
    assert SpindleStore("tul-mill", record).load() == 0


def test_the_record_is_replaced_atomically(record, monkeypatch):
    store = SpindleStore("tul-mill", record)
    store.save(7)

    def power_cut(src, dst):
        raise OSError("power cut before the rename")

    monkeypatch.setattr(os, "replace", power_cut)
    with pytest.raises(OSError):
        store.save(9)
    monkeypatch.undo()
    assert json.loads(record.read_text())["spindle_tool"] == 7       # the old record, whole
    assert [p.name for p in record.parent.iterdir()] == [record.name]   # no temporary left behind
    assert store.load() == 7
