"""The error every G-code rule raises; the program adds file and line (``prog.ngc:12: ...``)."""


class RuleError(Exception):
    """A rule of the G-code front end is broken; the compiler adds file and line."""

    file: str
    line: int


class NeedsWholeProgram(Exception):
    """Raised while the program is read ahead in batches (``readahead``) by a code whose meaning
    depends on every command before it (M62-M66 are timed on the program so far): the run reads
    the program whole instead."""
