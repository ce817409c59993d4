"""The position loop as a python-control model, and the same loop simulated, side by side.

Linear model of one servo axis (friction, feed rounding and the drive's +-255 limit left out):

* plant, feed units -> pulses:  P(s) = K / (s (tau s + 1)),  K = max velocity in pulses/s / 255,
  tau = J R / (Kt^2 + b R); sampled at the loop period with a zero-order hold (``c2d``);
* controller:  C(z) = kp + ki T z / (z - 1)  (the loop sums the error including this period's);
* the row's feedrate enters after the controller (feed-forward): y = P (ff + C (r - y)).

``control`` and matplotlib are imported inside the functions, not with ``retrofit.camlink``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MotionError
from ..machine.config import Machine
from .loop import PositionLoop, ServoAxis
from .motor import ServoMotor
from .servo import FEED_FULL_SCALE, servo_of


def plant(machine: Machine, axis: str = "X"):
    """Continuous transfer function from feed units to encoder pulses of one axis."""
    import control
    ax, servo = machine.axis(axis), servo_of(machine)
    gain, tau = servo.gain_pulses_s(ax), servo.time_constant_s
    return control.tf([gain], [tau, 1.0, 0.0])


def controller(machine: Machine):
    """The discrete P / PI controller of the loop, pulses of error -> feed units."""
    import control
    servo, dt = servo_of(machine), machine.tick_s
    kp, kit = servo.kp, servo.ki * dt
    if kit == 0.0:
        return control.tf([kp], [1.0], dt)
    return control.tf([kp + kit, -kp], [1.0, -1.0], dt)


@dataclass(frozen=True)
class LoopModel:
    """Discrete transfer functions of the closed loop of one axis."""

    plant: object            # P(z), feed -> pulses (zero-order hold)
    controller: object       # C(z)
    y_from_r: object         # C P / (1 + C P)
    e_from_r: object         # 1 / (1 + C P)
    e_from_ff: object        # -P / (1 + C P)
    dt: float


def loop_model(machine: Machine, axis: str = "X") -> LoopModel:
    """The closed loop sampled at the loop period (the machine's tick)."""
    import control
    dt = machine.tick_s
    pz = control.c2d(plant(machine, axis), dt, method="zoh")
    cz = controller(machine)
    open_loop = cz * pz
    return LoopModel(plant=pz, controller=cz, y_from_r=control.feedback(open_loop, 1),
                     e_from_r=control.feedback(control.tf([1.0], [1.0], dt), open_loop),
                     e_from_ff=-control.feedback(pz, cz), dt=dt)


def model_response(model: LoopModel, setpoint, feed) -> np.ndarray:
    """Predicted encoder position (pulses) for a set-point and feed-forward per loop period."""
    import control
    r = np.asarray(setpoint, dtype=float)
    ff = np.asarray(feed, dtype=float)
    t = np.arange(len(r)) * model.dt
    e = (control.forced_response(model.e_from_r, t, r).outputs
         + control.forced_response(model.e_from_ff, t, ff).outputs)
    return r - e


def simulate_response(machine: Machine, axis: str, setpoint, feed) -> np.ndarray:
    """Encoder position (pulses) read at the start of each period by the simulated loop."""
    ax, servo = machine.axis(axis), servo_of(machine)
    dt = machine.tick_s
    servo_axis = ServoAxis(ServoMotor(ax, servo, 0), PositionLoop(servo, dt), dt)
    return np.array([servo_axis.step(int(p), int(f)).encoder for p, f in zip(setpoint, feed)], float)


@dataclass(frozen=True)
class Comparison:
    """The same set-points through the python-control model and the simulated loop."""

    t_s: np.ndarray
    setpoint: np.ndarray     # pulses
    feed: np.ndarray         # the rows' feedrates (feed-forward)
    model: np.ndarray        # predicted encoder position, pulses
    sim: np.ndarray          # simulated encoder position, pulses

    def overshoot(self, which: str) -> float:
        """Overshoot of a step from 0 as a fraction of the step: (peak - step) / step."""
        y, step = getattr(self, which), float(self.setpoint[-1])
        return float((y.max() - step) / step) if step > 0 else float((step - y.min()) / -step)

    def following_error(self, which: str) -> np.ndarray:
        """Set-point minus position, pulses, per loop period."""
        return self.setpoint - getattr(self, which)


def step_rows(step_pulses: int, periods: int) -> tuple[np.ndarray, np.ndarray]:
    """A position step of ``step_pulses`` at period 0, no feed-forward."""
    return np.full(periods, step_pulses, dtype=np.int64), np.zeros(periods, dtype=np.int64)


def ramp_rows(machine: Machine, axis: str, speed_mm_s: float, periods: int,
              feedforward: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """A constant-speed ramp from 0: set-points in pulses and the rows' whole feedrates."""
    ax, servo = machine.axis(axis), servo_of(machine)
    pulses_per_period = speed_mm_s * ax.steps_per_mm * machine.tick_s
    setpoint = np.rint(np.arange(periods) * pulses_per_period).astype(np.int64)
    feed = round(speed_mm_s * ax.steps_per_mm / servo.gain_pulses_s(ax)) if feedforward else 0
    if abs(feed) > FEED_FULL_SCALE:
        raise MotionError(f"ramp of {speed_mm_s:g} mm/s needs feed {feed}; the drive takes -255..255")
    return setpoint, np.full(periods, feed, dtype=np.int64)


def compare(machine: Machine, axis: str, setpoint, feed) -> Comparison:
    """Run the python-control model and the simulated loop on the same rows; return both."""
    setpoint, feed = np.asarray(setpoint), np.asarray(feed)
    model = model_response(loop_model(machine, axis), setpoint, feed)
    sim = simulate_response(machine, axis, setpoint, feed)
    return Comparison(np.arange(len(setpoint)) * machine.tick_s, setpoint, feed, model, sim)


def step_comparison(machine: Machine, axis: str = "X", step_mm: float = 0.2,
                    periods: int = 200) -> Comparison:
    """Step response of model and simulation (keep the step small enough not to saturate)."""
    pulses = machine.axis(axis).to_steps(step_mm)
    return compare(machine, axis, *step_rows(pulses, periods))


def ramp_comparison(machine: Machine, axis: str = "X", speed_mm_s: float = 10.0,
                    periods: int = 300, feedforward: bool = True) -> Comparison:
    """Following error on a ramp from rest, model and simulation, with or without feed-forward."""
    return compare(machine, axis, *ramp_rows(machine, axis, speed_mm_s, periods, feedforward))


def plot_comparison(cmp: Comparison, path: str, title: str = "") -> str:
    """Save set-point, model and simulation (and the following errors) as a PNG; return path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    ms = cmp.t_s * 1e3
    top.plot(ms, cmp.setpoint, "k--", label="set-point")
    top.plot(ms, cmp.model, label="python-control model")
    top.plot(ms, cmp.sim, ":", label="simulated loop")
    top.set_ylabel("position, pulses")
    top.legend()
    bottom.plot(ms, cmp.following_error("model"), label="model")
    bottom.plot(ms, cmp.following_error("sim"), ":", label="simulation")
    bottom.set_xlabel("time, ms")
    bottom.set_ylabel("following error, pulses")
    bottom.legend()
    if title:
        top.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
