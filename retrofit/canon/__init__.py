"""The canon seam: the canonical machining calls a front end emits, and their commands.

The G-code interpreter (:mod:`retrofit.gcode`) speaks in canonical calls (:mod:`.calls`): a
straight traverse, a straight feed, an arc with its centre, a dwell, a feed rate, the spindle,
the coolant, a tool change, a digital output or input, a probing move, a pause, as LinuxCNC's
interpreter talks to its motion. :class:`~.tocommands.CommandCanon` turns each call into
commands of the instruction set (:mod:`retrofit.commands`); an arc is cut into chords there,
after the seam (:mod:`retrofit.motion.arcs`).
"""

from .calls import (
    ArcFeed,
    Call,
    ChangeTool,
    Coolant,
    DigitalOut,
    Dwell,
    Pause,
    SetFeedRate,
    Spindle,
    StartFeedSync,
    StopFeedSync,
    StraightFeed,
    StraightProbe,
    StraightTraverse,
    WaitInput,
    ZeroAxes,
)
from .tocommands import CommandCanon

__all__ = ["ArcFeed", "Call", "ChangeTool", "CommandCanon", "Coolant", "DigitalOut", "Dwell",
           "Pause", "SetFeedRate", "Spindle", "StartFeedSync", "StopFeedSync", "StraightFeed",
           "StraightProbe", "StraightTraverse", "WaitInput", "ZeroAxes"]
