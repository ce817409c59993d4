"""The error every G-code rule raises; the program adds file and line (``prog.ngc:12: ...``)."""


class RuleError(Exception):
    """A rule of the G-code front end is broken; the compiler adds file and line."""
