"""PROB, the probing move: its text form, the host's probe_over_link, and retrofit mcu's refusal."""

import itertools

import pytest

from retrofit.commands import CommandError, Init, Prob, Rdps, Rdst, parse_command
from retrofit.controller import Controller
from retrofit.errors import MotionError
from retrofit.link import DeviceEndpoint, HostLink, Position, Status, StatusFlags, probe_over_link
from retrofit.machine.config import load_machine
from retrofit.motion.planner import plan_program

MACHINE = "mitic-lathe"            # X 100, Z 80 steps/mm
LATHE = load_machine(MACHINE)
F = StatusFlags


# -- the text form ----------------------------------------------------------------------------

@pytest.mark.parametrize("text, cmd", [
    ("PROB X1 Z-40", Prob((("X", 1.0), ("Z", -40.0)))),
    ("PROB AWAY X1 Z-40", Prob((("X", 1.0), ("Z", -40.0)), away=True)),
    ("prob away z-2.5", Prob((("Z", -2.5),), away=True)),
], ids=["towards", "away", "lower-case"])
def test_prob_reads_from_its_text_and_writes_it_back(text, cmd):
    assert parse_command(text) == cmd
    assert parse_command(str(cmd)) == cmd
    assert str(cmd) == text.upper()


@pytest.mark.parametrize("text, message", [
    ("PROB X1 AWAY", "AWAY comes once, before the axis words, e.g. PROB AWAY X1 Z-40"),
    ("PROB AWAY AWAY Z1", "AWAY comes once"),
    ("PROB Z1 Z2", "PROB: axis Z given twice"),
    ("PROB TOWARDS Z1", "PROB: bad word 'TOWARDS'; expected a letter and a number"),
], ids=["away-last", "away-twice", "axis-twice", "unknown-word"])
def test_a_malformed_prob_says_what_is_accepted(text, message):
    with pytest.raises(CommandError, match=message):
        parse_command(text)


# -- the Python controller and a planned run have no probe input --------------------------------

def test_the_python_controller_refuses_prob_with_err_6_and_error_until_init():
    ctl = Controller(LATHE, kernels=False)
    reply = ctl.submit(parse_command("PROB Z-4"))
    assert (reply.code, reply.detail) == (6, 0x11)
    assert ctl.status.flags & F.ERROR
    assert "PROB Z-4: the controller of mitic-lathe has no probe input" in ctl.fault
    ctl.submit(Init())
    assert not ctl.status.flags & F.ERROR
    assert ctl.submit(parse_command("PMOV Z-1")) is None


def test_a_planned_run_refuses_prob_naming_the_command():
    with pytest.raises(MotionError, match=r"PROB AWAY Z1: a planned run has no probe input") as err:
        plan_program([parse_command("PMOV Z-1"), parse_command("PROB AWAY Z1")], LATHE)
    assert err.value.command_index == 1


# -- probe_over_link against a small device with a beam ----------------------------------------

class BeamLathe:
    """A device application with a probe on Z: its input is closed while Z <= ``beam_steps``.

    PROB moves Z ``per_poll`` steps each time RDST is asked (MOVING meanwhile) and stops at the
    first step after which the input is in the wanted state, as docs/protocol.md says.
    """

    def __init__(self, beam_steps: float, z: int = 0, per_poll: int = 100):
        self.beam, self.z, self.per_poll = beam_steps, z, per_poll
        self.target: int | None = None
        self.away = self.probed = False
        self.flags = F(0)

    def __call__(self, cmd):
        if isinstance(cmd, Prob):
            assert [n for n, _ in cmd.axes] == ["Z"]
            self.target, self.away, self.probed = LATHE.axis("Z").to_steps(cmd.axes[0][1]), cmd.away, False
            self._check()
            return None
        if isinstance(cmd, Rdst):
            for _ in range(self.per_poll):
                if self.target is None:
                    break
                self.z += 1 if self.target > self.z else -1
                self._check()
            moving = F.MOVING if self.target is not None else F(0)
            return Status(self.flags | moving | (F.PROBED if self.probed else F(0)), 0)
        if isinstance(cmd, Rdps):
            return Position((("X", 0), ("Z", self.z)))
        return None

    def _check(self) -> None:
        if (self.z <= self.beam) != self.away:
            self.probed, self.target = True, None
        elif self.z == self.target:
            self.target = None


class DirectPort:
    """A port wired straight to a DeviceEndpoint: what is written is answered at once."""

    def __init__(self, device: DeviceEndpoint):
        self.device, self.pending, self.timeout = device, b"", None

    def write(self, data: bytes) -> None:
        self.device.receive(data)
        self.pending += self.device.take_output()

    @property
    def in_waiting(self) -> int:
        return len(self.pending)

    def read(self, size: int = 1) -> bytes:
        out, self.pending = self.pending[:size], self.pending[size:]
        return out


def probe(app: BeamLathe, text: str, **options):
    """probe_over_link on a fake clock; (result, sleeps between RDSTs)."""
    ticks = itertools.count()
    link = HostLink(DirectPort(DeviceEndpoint(LATHE, app)), LATHE, clock=lambda: next(ticks) * 1e-3)
    sleeps = []
    result = probe_over_link(link, parse_command(text), clock=lambda: len(sleeps) * 0.02,
                             sleep=sleeps.append, **options)
    return result, len(sleeps)


# The beam at Z -12.34 mm is -987.2 steps (80 steps/mm): the input closes at -988 and opens at -987.
# The device moves 100 steps per RDST, so a move of d steps is busy at ceil(d / 100) - 1 RDSTs.
@pytest.mark.parametrize("start, text, probed, z, sleeps", [
    (0, "PROB Z-40", True, -988, 9),            # closes on the way down
    (-988, "PROB AWAY Z0", True, -987, 0),      # opens on the first step up
    (0, "PROB Z-5", False, -400, 3),            # ends short of the beam: PROBED clear, no error
    (-988, "PROB Z-40", True, -988, 0),         # already closed: no step
], ids=["towards", "away", "miss", "already"])
def test_probe_over_link_reports_the_stop_and_whether_the_probe_stopped_it(start, text, probed, z,
                                                                          sleeps):
    result, slept = probe(BeamLathe(-987.2, z=start), text)
    assert result.probed is probed and result.steps == {"X": 0, "Z": z}
    probed_flag, steps = result                          # unpacks as (probed, steps)
    assert probed_flag is probed and result.mm(LATHE)["Z"] == pytest.approx(z / 80)
    assert slept == sleeps                               # it waited until the move had ended


def test_probe_over_link_fails_when_the_device_reports_error_or_the_wait_runs_out():
    faulty = BeamLathe(-987.2)
    faulty.flags = F.ERROR
    with pytest.raises(MotionError, match=r"PROB Z-40 over DirectPort: the device reports ERROR "
                                          r"\(status MOVING, ERROR\); the probing move did not end"):
        probe(faulty, "PROB Z-40")
    with pytest.raises(MotionError, match=r"still busy when the wait ran out \(status MOVING, 0 "
                                          r"queued\)"):
        probe(BeamLathe(-987.2, per_poll=1), "PROB Z-40", wait_s=0.1)
