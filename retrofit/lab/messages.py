"""A failed check in words: a sentence a student can act on (never a traceback), and a few words
for a grades table (wrong value, timeout at line 6, did not import)."""

from __future__ import annotations

import traceback
from pathlib import Path

from .wire import CheckTimeout, StudentProcessEnded


class CheckFailed(AssertionError):
    """A check that failed, worded for a student: what was checked, expected, got, and a hint."""

    def __init__(self, what: str, expected, got, hint: str = ""):
        self.what, self.expected, self.got, self.hint = what, expected, got, hint
        lines = [what, f"expected: {expected}", f"your code gave: {got}"]
        if hint:
            lines.append(f"hint: {hint}")
        super().__init__("\n".join(lines))


def explain(exc: BaseException, target: Path) -> str:
    """A failure in words a student can act on, never a traceback.

    >>> explain(NotImplementedError("TODO 1: compute the target"), Path("student.py"))
    'not written yet: TODO 1: compute the target'
    """
    if isinstance(exc, CheckFailed):
        return str(exc)
    if isinstance(exc, CheckTimeout):
        where = _where(exc, target)
        return (f"{exc}; a loop that never ends?" + (f" it was running {where}" if where else "")
                + "; look at that loop's exit condition")
    if isinstance(exc, SyntaxError) and exc.filename and Path(exc.filename).name == target.name:
        return (f"{target.name} line {exc.lineno} does not read as Python: {exc.msg}; "
                "fix that line, then check again")
    where = _where(exc, target)
    if isinstance(exc, StudentProcessEnded):
        return str(exc)
    if isinstance(exc, NotImplementedError):
        return f"not written yet: {exc or 'a TODO'}" + (f" ({where})" if where else "")
    if type(exc) is AssertionError:
        return str(exc).split("\nassert ")[0] or "a check's assertion failed"
    text = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    if where:
        return f"your code raised {text} ({where}); fix it there, then check again"
    return f"the check raised {text} while using your code; look at what your functions return"


def failure_reason(exc: BaseException) -> str:
    """A failure in a few words for a grades table: wrong value, timeout at line 6, did not import ..."""
    where = getattr(exc, "student_where", "") or ""
    line = f" at line {where.split(' line ')[1].split(',')[0]}" if " line " in where else ""
    if getattr(exc, "at_import", False):
        if isinstance(exc, CheckTimeout):
            return f"did not import: timeout{line}"
        return f"did not import: {type(exc).__name__}" + (f" at line {exc.lineno}" if isinstance(exc, SyntaxError)
                                                         else line)
    if isinstance(exc, CheckFailed) or type(exc) is AssertionError:
        return "wrong value"
    if isinstance(exc, CheckTimeout):
        return f"timeout{line}"
    if isinstance(exc, StudentProcessEnded):
        return "program ended"
    if isinstance(exc, NotImplementedError):
        return "not written"
    if where:
        return f"raised {type(exc).__name__}{line}"
    return f"check error: {type(exc).__name__}"


def _where(exc: BaseException, target: Path) -> str:
    """'student.py line 42, in calc_next_input' for the deepest frame in the target file."""
    if getattr(exc, "student_where", ""):
        return exc.student_where
    frames = [f for f in traceback.extract_tb(exc.__traceback__) if Path(f.filename).name == target.name]
    if not frames:
        return ""
    frame = frames[-1]
    return f"{target.name} line {frame.lineno}, in {frame.name}"
