"""Any sequence of T commands: never a violation, and the requested tool ends in the spindle."""

from hypothesis import given, settings
from hypothesis import strategies as st

from retrofit.atc.cell import SimCell
from retrofit.atc.magazine import MagazineState
from retrofit.atc.sequences import change_sequence
from retrofit.atc.settings import atc_of
from retrofit.machine.config import load_machine

MILL = load_machine("tul-mill")
ATC = atc_of(MILL)
TOOLS = st.integers(0, ATC.pockets)


@settings(max_examples=30)
@given(start=TOOLS, requests=st.lists(TOOLS, min_size=1, max_size=6),
       where=st.tuples(st.integers(0, 45), st.integers(0, 30), st.integers(-45, 0)))
def test_random_tool_changes_never_violate_and_end_with_the_requested_tool(start, requests, where):
    cell = SimCell(MILL, MagazineState.loaded(MILL, start), start_mm=dict(zip("XYZ", map(float, where))))
    current = start
    for tool in requests:
        cell.run(change_sequence(ATC, current, tool, MILL.name).commands())
        current = tool
        state = cell.magazine.state
        assert state.spindle == (tool or None)
        assert state.pockets == {p: (None if p == tool else p) for p in range(1, ATC.pockets + 1)}
    assert cell.violations == []
    assert cell.carriage_mm()["E"] == ATC.atc_home            # the door is closed
