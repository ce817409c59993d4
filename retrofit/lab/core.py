"""Lab exercises: find the labs folder, run a lab's file, and check it with messages written for students.

A lab is a folder ``labs/NN_topic/`` holding ``README.md`` (the handout), ``student.py`` (the
file the student completes, with ``TODO`` markers), ``solution.py`` (the reference solution:
the same file completed) and ``checks.py`` (pytest tests). Each lab file has a
``main(out_dir)`` that draws the lab's plots into ``out_dir`` and returns the files written.

Where the labs folder is, first found wins:

1. the ``--labs DIR`` option of ``retrofit lab`` (the ``root`` argument here);
2. the environment variable ``RETROFIT_LABS``;
3. ``labs/`` next to the ``retrofit`` package, i.e. the repository's own ``labs/`` when retrofit
   is installed editable (``pip install -e .``) or run from a checkout;
4. ``labs/`` in the current directory.

Which file the checks test: ``RETROFIT_LAB_TARGET`` = ``student`` (the default), ``solution``,
or a path to any ``.py`` file; the checks get the module from :func:`load_target`. So
``pytest labs/01_circle/checks.py`` checks the student's file and
``RETROFIT_LAB_TARGET=solution pytest labs/01_circle/checks.py`` the reference solution.

The file under check runs in a process of its own (:mod:`retrofit.lab.proxy`): :func:`load_target`
gives the checks a proxy of its module, and the checks and the score stay in this process.
``RETROFIT_LAB_SANDBOX=0`` imports it here instead (to debug a lab's checks, never to grade).
"""

from __future__ import annotations

import importlib.util
import os
import re
import signal
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError
from .messages import CheckFailed, explain, failure_reason  # noqa: F401  (part of this module's API)
from .plot import pyplot, save_figure  # noqa: F401  (the labs draw with these)
from .process import BUDGET
from .proxy import CheckTimeout, close_all

LABS_ENV = "RETROFIT_LABS"
TARGET_ENV = "RETROFIT_LAB_TARGET"
SANDBOX_ENV = "RETROFIT_LAB_SANDBOX"            # "0": the file under check is imported in this process
SPEC_ENV = "RETROFIT_LAB_SANDBOX_SPEC"          # the grader's sandbox settings (JSON of labprocess.Sandbox)
_LAB_DIR = re.compile(r"^(\d\d)_([A-Za-z0-9_]+)$")


@dataclass(frozen=True)
class Lab:
    """One lab folder ``NN_topic``."""

    number: str         # "01"
    topic: str          # "circle"
    path: Path
    title: str          # the first heading of its README.md

    @property
    def checks(self) -> Path:
        return self.path / "checks.py"

    def file(self, solution: bool = False) -> Path:
        """The student's file, or the reference solution."""
        return self.path / ("solution.py" if solution else "student.py")


def labs_dir(root: str | Path | None = None) -> Path:
    """The labs folder (see the module doc for the order it is looked for in)."""
    if root is not None or os.environ.get(LABS_ENV):
        path = Path(root if root is not None else os.environ[LABS_ENV])
        if not path.is_dir():
            where = "--labs" if root is not None else LABS_ENV
            raise ConfigError(f"{where} {path}: no such folder; give the folder that holds 01_circle/ ...")
        return path.resolve()
    package = Path(__file__).resolve().parent.parent
    for candidate in (package.parent / "labs", Path.cwd() / "labs"):
        if candidate.is_dir() and list_labs(candidate):
            return candidate
    raise ConfigError(f"no labs folder found (looked in {package.parent / 'labs'} and ./labs); "
                      f"give --labs DIR or set {LABS_ENV}")


def list_labs(root: str | Path) -> list[Lab]:
    """Every ``NN_topic`` folder with a README.md, in number order."""
    labs = []
    for path in sorted(Path(root).iterdir()):
        match = _LAB_DIR.match(path.name)
        if match and path.is_dir() and (path / "README.md").is_file():
            labs.append(Lab(match[1], match[2], path, _title(path / "README.md")))
    return labs


def _title(readme: Path) -> str:
    for line in readme.read_text(encoding="utf-8").splitlines():
        if line.startswith("# "):
            return line[2:].strip()
    return readme.parent.name


def find_lab(root: str | Path, key: str) -> Lab:
    """A lab by number (``1``, ``01``), folder name (``01_circle``) or topic (``circle``)."""
    labs = list_labs(root)
    for lab in labs:
        if key in (lab.number, lab.path.name, lab.topic) or (key.isdigit() and int(key) == int(lab.number)):
            return lab
    known = ", ".join(lab.path.name for lab in labs) or "none"
    raise ConfigError(f"no lab {key!r} in {root}; labs: {known}")


def load_module(path: str | Path):
    """Import a lab file afresh (a new module each time, so edits and targets take effect)."""
    path = Path(path)
    name = "retrofit_lab_" + re.sub(r"\W", "_", f"{path.parent.name}_{path.stem}")
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ConfigError(f"{path}: not a Python file")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def target_path(lab_path: str | Path) -> Path:
    """The file the checks of the lab in ``lab_path`` test, chosen by ``RETROFIT_LAB_TARGET``."""
    choice = os.environ.get(TARGET_ENV, "student") or "student"
    if choice in ("student", "solution"):
        return Path(lab_path) / f"{choice}.py"
    path = Path(choice)
    if not path.is_file():
        raise ConfigError(f"{TARGET_ENV}={choice}: no such file; use student, solution or a path to a .py file")
    return path


def load_target(checks_file: str | Path):
    """For a lab's ``checks.py``: the module under check (the student's file by default).

    A proxy of the module, running in its sandbox; calls on it and on what it returns go to that
    process (see :mod:`retrofit.lab.wire` for the values that cross).
    """
    lab_path = Path(checks_file).resolve().parent
    path = target_path(lab_path)
    if os.environ.get(SANDBOX_ENV, "1") == "0":
        return load_module(path)
    from .process import Sandbox, sandbox_uid
    from .proxy import open_target
    spec = os.environ.get(SPEC_ENV)
    sandbox = Sandbox.from_env(spec) if spec else Sandbox(uid=sandbox_uid(), hide=[str(lab_path.parent)])
    return open_target(path.resolve(), lab_path, sandbox)


def expect(ok: bool, what: str, *, expected, got, hint: str = "") -> None:
    """Raise :class:`CheckFailed` unless ``ok``."""
    if not ok:
        raise CheckFailed(what, expected, got, hint)


#: processor seconds one check may take before it is stopped as a hang (``RETROFIT_CHECK_SECONDS`` changes it)
CHECK_SECONDS = 20.0
CHECK_SECONDS_ENV = "RETROFIT_CHECK_SECONDS"
_TODO = re.compile(r"\bTODO\s*(\d+)")
_TODOS = re.compile(r"^TODOs? ([\d, -]+)")


@dataclass(frozen=True)
class CheckResult:
    """One check: its title (the first line of its docstring), passed / failed / skipped, and why."""

    title: str
    status: str
    message: str = ""
    points: int = 1             # what the check is worth (``@pytest.mark.points(n)``)
    reason: str = ""            # a failure in a few words: wrong value, timeout at line 6, did not import

    @property
    def todo(self) -> str:
        """The TODO the check names ("TODO 2"), or "" when its title names none."""
        match = _TODO.search(self.title)
        return f"TODO {match[1]}" if match else ""

    @property
    def todos(self) -> list[str]:
        """Every TODO the title names: "TODO 1, 2: ..." and "TODOs 1-3: ..." name them all."""
        match = _TODOS.match(self.title)
        if not match:
            return [self.todo] if self.todo else []
        numbers = []
        for part in re.findall(r"\d+-\d+|\d+", match[1]):
            low, _, high = part.partition("-")
            numbers += range(int(low), int(high or low) + 1)
        return [f"TODO {n}" for n in dict.fromkeys(numbers)]

    @property
    def scored(self) -> int:
        """Points earned: all of them when the check passed, none otherwise."""
        return self.points if self.status == "passed" else 0

    def as_dict(self) -> dict:
        """The result as plain data for ``--json``: title, TODO, status, message, points."""
        return {"title": self.title, "todo": self.todo, "todos": self.todos, "status": self.status,
                "message": self.message, "reason": self.reason, "points": self.scored, "max_points": self.points}


def check_seconds() -> float:
    """The per-check time limit: ``RETROFIT_CHECK_SECONDS`` if set, else :data:`CHECK_SECONDS`."""
    text = os.environ.get(CHECK_SECONDS_ENV, "")
    try:
        return float(text) if text else CHECK_SECONDS
    except ValueError:
        raise ConfigError(f"{CHECK_SECONDS_ENV}={text}: not a number; give the seconds one check may take, "
                          "e.g. 10") from None


class _Alarm:
    """Stop a check that runs longer than ``seconds`` by raising :class:`CheckTimeout` inside it.

    The limit counts the processor time of this process (SIGPROF), so a loaded machine does not
    fail a check that is only waiting its turn, with ten times as much wall time (SIGALRM) as a
    backstop for code that hangs without computing. Only in the main thread of a POSIX process;
    elsewhere the check runs without a limit (the grader's process limits still hold).
    """

    TIMERS = (("ITIMER_PROF", "SIGPROF", 1), ("ITIMER_REAL", "SIGALRM", 12))

    def __init__(self, seconds: float, title: str):
        self.seconds, self.title = seconds, title
        self.usable = (hasattr(signal, "setitimer") and seconds > 0
                       and threading.current_thread() is threading.main_thread())

    def _fire(self, signum, frame):
        raise CheckTimeout(f"{self.title}: did not finish within {self.seconds:g} s")

    def __enter__(self):
        if self.seconds > 0:
            BUDGET.begin(self.seconds, self.title)   # the student's process is timed by labproxy
        if self.usable:
            self.saved = []
            for timer, sig, times in self.TIMERS:
                self.saved.append(signal.signal(getattr(signal, sig), self._fire))
                signal.setitimer(getattr(signal, timer), self.seconds * times)
        return self

    def __exit__(self, *exc):
        BUDGET.end()
        if self.usable:
            for (timer, sig, _), handler in zip(self.TIMERS, self.saved):
                signal.setitimer(getattr(signal, timer), 0)
                signal.signal(getattr(signal, sig), handler)
        return False


def _collector(target: Path):
    """A pytest plugin that records each check's outcome with a student-facing message."""
    import pytest

    seconds = check_seconds()

    class Collector:
        def __init__(self):
            self.results: list[CheckResult] = []

        @pytest.hookimpl(wrapper=True)
        def pytest_runtest_setup(self, item):      # loading the file: a loop at module level
            with _Alarm(seconds, _check_title(item)):
                return (yield)

        @pytest.hookimpl(wrapper=True)
        def pytest_runtest_call(self, item):
            with _Alarm(seconds, _check_title(item)):
                return (yield)

        @pytest.hookimpl(wrapper=True)
        def pytest_runtest_makereport(self, item, call):
            report = yield
            if report.when == "call" or not report.passed:
                title = _check_title(item)
                marker = item.get_closest_marker("points")
                points = int(marker.args[0]) if marker and marker.args else 1
                if report.skipped:
                    reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else ""
                    self.results.append(CheckResult(title, "skipped", reason.removeprefix("Skipped: "), points))
                elif report.failed:
                    exc = call.excinfo.value
                    self.results.append(CheckResult(title, "failed", explain(exc, target), points, failure_reason(exc)))
                else:
                    self.results.append(CheckResult(title, "passed", "", points))
            return report

        def pytest_collectreport(self, report):
            if report.failed:
                text = str(report.longrepr).strip().splitlines()
                self.results.append(CheckResult("the checks load", "failed", text[-1] if text else ""))

    return Collector()


def _check_title(item) -> str:
    """A check's title: the first line of its docstring, else its name; with its parameters."""
    function = getattr(item, "function", None)
    doc = (function.__doc__ or "").strip() if function is not None else ""
    title = doc.splitlines()[0] if doc else item.name.removeprefix("test_").replace("_", " ")
    if getattr(item, "callspec", None) is not None:
        title += f" [{item.callspec.id}]"
    return title


#: pytest plugins a lab check does without: its own report replaces the terminal's, nothing is
#: cached or stored in the labs folder (pytest's cache, pytest-benchmark's .benchmarks), and no
#: garbage collection after every check (slow in a big process)
_QUIET = ("-p", "no:terminal", "-p", "no:cacheprovider", "-p", "no:benchmark", "-p", "no:unraisableexception",
          "-p", "no:threadexception")


def check_lab(lab: Lab, solution: bool = False, target: str | Path | None = None,
              first_failure: bool = False) -> list[CheckResult]:
    """Run a lab's checks against the student's file, the solution, or ``target``; one result per check.

    Each check may run :func:`check_seconds` seconds; ``first_failure`` stops at the first failed check.
    """
    try:
        import pytest
    except ImportError:
        raise ConfigError("the lab checks need pytest: python3 -m pip install -e '.[test]'") from None
    chosen = Path(target) if target is not None else lab.file(solution)
    collector = _collector(chosen)
    saved = os.environ.get(TARGET_ENV)
    os.environ[TARGET_ENV] = str(chosen.resolve())
    _forget_checks()
    try:
        code = pytest.main([str(lab.checks), "--import-mode=importlib", "--rootdir", str(lab.path.parent),
                            "-W", "ignore::DeprecationWarning", *_QUIET, *(["-x"] if first_failure else [])],
                           plugins=[collector])
    finally:
        close_all()
        if saved is None:
            os.environ.pop(TARGET_ENV, None)
        else:
            os.environ[TARGET_ENV] = saved
    if not collector.results:
        collector.results.append(CheckResult("the checks run", "failed",
                                             f"{lab.checks} ran no checks (pytest exit code {int(code)})"))
    return collector.results


def _forget_checks() -> None:
    """Drop checks modules a previous run imported, so every lab's own checks.py is read afresh."""
    for name, module in list(sys.modules.items()):
        if Path(getattr(module, "__file__", None) or "").name == "checks.py":
            del sys.modules[name]


def result_lines(results: list[CheckResult], ascii_only: bool = False) -> list[str]:
    """One line per check (✓ / ✗ / –), the message indented under a failure, and a summary."""
    marks = {"passed": "ok", "failed": "FAIL", "skipped": "skip"} if ascii_only else \
        {"passed": "✓", "failed": "✗", "skipped": "–"}
    lines = []
    for r in results:
        lines.append(f"  {marks[r.status]} {r.title}" + (f" ({r.message})" if r.status == "skipped" and r.message else ""))
        if r.status == "failed":
            lines += [f"      {text}" for text in r.message.splitlines()]
    count = {status: sum(r.status == status for r in results) for status in marks}
    summary = f"{count['passed']} of {len(results)} checks pass"
    summary += f", {count['skipped']} skipped" if count["skipped"] else ""
    summary += f", {count['failed']} to fix" if count["failed"] else "; well done"
    return lines + [summary]


def run_lab(lab: Lab, solution: bool = False, out_dir: str | Path | None = None) -> list[Path]:
    """Run a lab file's ``main(out_dir)`` (default ``<lab>/out``); return the files it wrote."""
    pyplot()
    out = Path(out_dir) if out_dir is not None else lab.path / "out"
    out.mkdir(parents=True, exist_ok=True)
    module = load_module(lab.file(solution))
    written = module.main(out)
    return [Path(p) for p in written or []]
