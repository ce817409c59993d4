"""The simulator: a machine moved only by what comes out of the controller."""

from .drivers import Violation
from .machine import SimMachine

__all__ = ["SimMachine", "Violation"]
