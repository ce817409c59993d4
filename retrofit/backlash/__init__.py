"""Backlash: the controller's compensation and the simulator's physical dead band."""

from .compensation import BacklashCompensator
from .deadband import DeadBand

__all__ = ["BacklashCompensator", "DeadBand"]
