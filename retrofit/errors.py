"""The one error hierarchy of retrofit: each message says where, what, the rule, what is accepted."""


class RetrofitError(Exception):
    """Base of every error retrofit raises on purpose."""


class ConfigError(RetrofitError, ValueError):
    """A machine file (or an option) is missing, mistyped or out of range."""


class GcodeError(RetrofitError, ValueError):
    """A part program breaks a rule; carries the file and line it came from."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None):
        self.file, self.line, self.rule = file, line, message
        where = f"{file}:{line}: " if file and line else (f"{file}: " if file else "")
        super().__init__(f"{where}{message}")


class LinkError(RetrofitError, OSError):
    """A serial or TCP link failed or its peer broke the protocol."""


class OutputError(RetrofitError, OSError):
    """An output (sim, port, file) cannot be opened or written."""


class MotionError(RetrofitError, ValueError):
    """A move cannot be made: outside the step space, the soft limits, or the machine's reach."""

    command_index: int | None   # the index of the command at fault, where it is known (not always set)


class ToolChangeError(RetrofitError, ValueError):
    """A tool change or a tool measurement is refused: a tool number out of range, no reference."""


class ToolStateError(RetrofitError, ValueError):
    """The record of the tool in the spindle (or the tool table) cannot be trusted or read."""


class ProbeError(RetrofitError, RuntimeError):
    """A probing move ended without the tool setter's beam breaking."""
