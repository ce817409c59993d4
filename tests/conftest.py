"""Shared test set-up: headless plots, hypothesis profiles (deterministic in the main stage; fresh
examples under a printed seed in the slow stage: HYPOTHESIS_PROFILE=fresh, --hypothesis-seed=N)."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile("ci", deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("fresh", deadline=None, derandomize=False, database=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


import pytest  # noqa: E402


def pytest_report_header(config):
    """The profile, and the seed that draws this run's examples again."""
    profile = settings.get_current_profile_name()
    seed = config.getoption("hypothesis_seed", None)
    if profile != "fresh":
        return f"hypothesis: profile {profile} (the same examples every run)"
    if seed is None:
        return "hypothesis: profile fresh, no seed given: examples cannot be drawn again (give --hypothesis-seed)"
    return (f"hypothesis: profile fresh, seed {seed}; again: HYPOTHESIS_PROFILE=fresh python3 -m pytest "
            f"-m slow --hypothesis-seed={seed}")


@pytest.fixture(autouse=True)
def machine_state_in_tmp(tmp_path_factory, monkeypatch):
    """Every test keeps the machines' state (tool tables, spindle records) in a folder of its own,
    never in the user's home: XDG_STATE_HOME points there (subprocesses inherit it)."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path_factory.mktemp("state")))
    monkeypatch.delenv("RETROFIT_STATE_DIR", raising=False)


@pytest.fixture(autouse=True)
def ctrl_c_handler_restored():
    """A test that runs the command line in this process and ends it by Ctrl-C leaves SIGINT
    ignored (the command's "one Ctrl-C ends the run"); restore it, or every later subprocess of
    this worker would inherit a Ctrl-C that does nothing."""
    import signal
    handler = signal.getsignal(signal.SIGINT)
    yield
    signal.signal(signal.SIGINT, handler)


@pytest.fixture(autouse=True)
def sigpipe_ignored():
    """Every test starts with Python's own SIGPIPE disposition (ignored: a write to a closed
    socket raises BrokenPipeError): vcdvcd sets it to the default action when imported, which
    every worker does while collecting, and a write to a peer that has gone then killed the
    worker (tests/test_sigpipe_between_tests.py)."""
    import signal
    signal.signal(signal.SIGPIPE, signal.SIG_IGN)
    yield


@pytest.fixture(scope="session", autouse=True)
def machine_state_in_tmp_for_wider_fixtures(tmp_path_factory):
    """Fixtures wider than one test (a module's console, set up before any test's own fixtures)
    keep the machines' state out of the home as well."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("XDG_STATE_HOME", str(tmp_path_factory.mktemp("session-state")))
        patch.delenv("RETROFIT_STATE_DIR", raising=False)
        yield
