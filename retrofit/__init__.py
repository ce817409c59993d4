"""retrofit: turn an old lathe or mill with stepper motors into a numerically controlled machine."""

from .config import Axis, Machine, list_machines, load_machine
from .errors import ConfigError, GcodeError, LinkError, MotionError, OutputError, RetrofitError

__version__ = "0.1.0"

__all__ = ["Axis", "Machine", "list_machines", "load_machine", "ConfigError", "GcodeError",
           "LinkError", "MotionError", "OutputError", "RetrofitError", "__version__"]
