"""Every code example in docs/*.md runs: python blocks are executed, `retrofit ...` lines of sh blocks are
run as commands, json and toml blocks must parse.

Pages are found when the tests are collected, so a new page is checked without touching this file.
Fence languages: ```python (executed, the blocks of one page in order, in one namespace, in a
temporary directory, headless), ```sh (lines starting with `retrofit ` run as CLI commands in that
page's temporary directory, except the kinds in SKIPPED below), ```json / ```toml (parsed). Any
other language (text, c, console, none) is shown, not run: use it for output, fragments, and
commands of other programs.
"""

import json
import os
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parent.parent / "docs"
PAGES = sorted(DOCS.glob("*.md"))

#: commands the test suite cannot run, and why: a real port, a server or a board is needed
SKIPPED = {
    r"parport://": "drives a real parallel port",
    r"serial://": "drives a real serial board",
    r"^retrofit serve\b": "starts a server that runs until stopped",
    r"^retrofit send\b": "needs a running CAM link server",
    r"^retrofit mcu\b": "talks to a microcontroller board",
    r"^make flash\b": "programs a microcontroller board",
    r"\bPROGRAM\b": "PROGRAM stands for the reader's own program",
    r"^retrofit fpga build\b": "builds a bitstream (half a minute); tests/test_fpga_build.py runs it in the slow stage",
}

_FENCE = re.compile(r"^(?P<indent>\s*)```(?P<lang>[\w+-]*)\s*$")


def blocks(page: Path) -> list[tuple[str, int, str]]:
    """(language, first line number, text) of every fenced block of a page."""
    found, lang, start, indent, body = [], None, 0, "", []
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
        match = _FENCE.match(line)
        if lang is None and match:
            lang, start, indent, body = match["lang"].lower(), number + 1, match["indent"], []
        elif lang is not None and match and not match["lang"]:
            found.append((lang, start, "\n".join(body)))
            lang = None
        elif lang is not None:
            body.append(line[len(indent):] if line.startswith(indent) else line.lstrip())
    return found


def commands(page: Path) -> list[tuple[str, int, str]]:
    """(page name, line number, command) of every `retrofit ...` line in the page's sh blocks."""
    out = []
    for lang, start, text in blocks(page):
        if lang in ("sh", "bash", "shell"):
            for offset, line in enumerate(text.splitlines()):
                line = line.strip().removeprefix("$ ")
                if line.startswith("retrofit ") or line.startswith("make flash"):
                    out.append((page.name, start + offset, line))
    return out


COMMANDS = [c for page in PAGES for c in commands(page)]


def test_the_docs_have_examples_to_run():
    assert PAGES and COMMANDS
    assert any(lang == "python" for page in PAGES for lang, _, _ in blocks(page))


@pytest.mark.parametrize("page", [p for p in PAGES if any(b[0] in ("python", "py") for b in blocks(p))],
                         ids=lambda p: p.name)
def test_python_examples_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace = {"__name__": "__docs__"}
    for lang, start, text in blocks(page):
        if lang not in ("python", "py"):
            continue
        try:
            exec(compile(text, f"{page.name}:{start}", "exec"), namespace)
        except Exception as exc:
            pytest.fail(f"{page.name}, the python block at line {start}: {type(exc).__name__}: {exc}")


@pytest.mark.parametrize("page", [p for p in PAGES if any(b[0] in ("json", "toml") for b in blocks(p))],
                         ids=lambda p: p.name)
def test_json_and_toml_examples_parse(page):
    for lang, start, text in blocks(page):
        try:
            if lang == "json":
                json.loads(text)
            elif lang == "toml":
                tomllib.loads(text)
        except ValueError as exc:
            pytest.fail(f"{page.name}, the {lang} block at line {start} does not parse: {exc}")


@pytest.fixture(scope="module")
def page_dir(tmp_path_factory):
    """One working directory per page, shared by its commands (a later one may read an earlier's file,
    or the machine state it left)."""
    made = {}

    def folder(page: str) -> Path:
        if page not in made:
            made[page] = tmp_path_factory.mktemp(page.replace(".", "_"))
        return made[page]
    return folder


@pytest.mark.parametrize("page,line,command", COMMANDS, ids=[f"{p}:{n}" for p, n, _ in COMMANDS])
def test_cli_examples_run(page, line, command, page_dir):
    for pattern, why in SKIPPED.items():
        if re.search(pattern, command):
            pytest.skip(f"{page}:{line} `{command}`: {why}")
    folder = page_dir(page)
    args = shlex.split(command, comments=True)[1:]
    # the machines' state (tool table, spindle record) is the page's too: a later command sees it
    env = dict(os.environ, MPLBACKEND="Agg", XDG_STATE_HOME=str(folder / ".state"))
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", *args], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, f"{page}:{line} `{command}` exited {proc.returncode}:\n{proc.stderr[-2000:]}"


def test_machine_file_reference_names_every_key(monkeypatch):
    """docs/machine-files.md names every key the loader reads from the shipped machine files."""
    from retrofit.machine import tomlreader
    from retrofit.machine.config import SECTION_PARSERS, list_machines, load_machine
    read = set()
    for getter in ("get_float", "get_int", "get_bool", "get_str", "get_list"):
        def recording(self, key, *args, _original=getattr(tomlreader.Section, getter), **kwargs):
            read.add((self.name, key))
            return _original(self, key, *args, **kwargs)
        monkeypatch.setattr(tomlreader.Section, getter, recording)
    for name in list_machines():
        load_machine(name)
    for extra in sorted((DOCS.parent / "labs").glob("*/*.toml")):
        load_machine(extra)
    reference = (DOCS / "machine-files.md").read_text(encoding="utf-8")
    missing = sorted(f"[{section}] {key}" for section, key in read
                     if len(key) > 1 and f"`{key}`" not in reference)     # one letter: an axis name
    assert not missing, f"docs/machine-files.md does not describe: {', '.join(missing)}"
    sections = [name for name in SECTION_PARSERS if f"[{name}" not in reference]
    assert not sections, f"docs/machine-files.md has no section for: {', '.join(sections)}"
