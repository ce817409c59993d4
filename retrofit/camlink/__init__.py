"""The CAM link of the Grenoble mill: `@`-terminated TCP protocol, 1 ms rows, servo position loop.

``protocol`` parses and formats the messages, ``machine`` is the simulated closed-loop mill that
executes them, ``server`` puts it behind a TCP socket, ``trajectory`` and ``client`` are the CAM
side, ``model`` is the same loop as a python-control model (``control`` is imported only there).
"""

from .protocol import LineSplitter, Row, format_message, parse_message
from .servo import ServoSettings, read_servo_section

__all__ = ["LineSplitter", "Row", "ServoSettings", "format_message", "parse_message",
           "read_servo_section"]
