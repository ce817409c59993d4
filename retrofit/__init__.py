"""retrofit: turn an old lathe or mill with stepper motors into a numerically controlled machine.

The names below load on first use, so ``python3 -m retrofit.cli`` reaches its Ctrl-C handling
before any module of the toolkit is read.
"""

from importlib import import_module

__version__ = "0.1.0"

_HOMES = {"Axis": "machine.config", "Machine": "machine.config", "list_machines": "machine.config", "load_machine": "machine.config",
          "ConfigError": "errors", "GcodeError": "errors", "LinkError": "errors", "MotionError": "errors",
          "OutputError": "errors", "RetrofitError": "errors"}

__all__ = [*_HOMES, "__version__"]


def __getattr__(name: str):
    if name in _HOMES:
        value = getattr(import_module(f".{_HOMES[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'retrofit' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HOMES))
