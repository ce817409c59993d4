"""The student's file in its sandbox: what crosses the boundary and what does not, who it runs as,
what it can see; and the teacher's side: `lab export` hands out the committed stub, `--labs` may
be relative."""

import csv
import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from retrofit.cli import main
from retrofit.commands import PMov
from retrofit.errors import ConfigError
from retrofit.lab import wire as labwire
from retrofit.lab.core import find_lab
from retrofit.lab.kit import export_lab
from retrofit.lab.process import Sandbox, sandbox_uid
from retrofit.lab.proxy import close_all, open_target
from retrofit.machine.config import load_machine

from tests.test_lab_grader_attacks import STUB, make_lab
from tests.test_lab_kit import RIGHT

ROOT = os.geteuid() == 0
STUDENT = '''
import dataclasses, os
import numpy as np
from retrofit.commands import PMov
from retrofit.machine.config import load_machine

@dataclasses.dataclass
class State:
    x: float = 1.5

class AlwaysEqual:
    def __eq__(self, other):
        return True

def values():
    return {"int": 2 ** 70, "nan": float("nan"), "tuple": (1, "a"), "list": [1.0, None], "keys": {(1, 2): b"\\x00"},
            "set": {3}, "complex": 1 - 2j, "array": np.arange(6, dtype=np.int64).reshape(2, 3),
            "f32": np.float32(0.25), "machine": load_machine("chivu-lathe"), "command": PMov((("X", 1.25),))}

def state():
    return State()

def cheat():
    return AlwaysEqual()

def objects():
    return np.array([AlwaysEqual()], dtype=object)

def call_back(counter, times):
    return [counter.tick() for _ in range(times)]

def peek(counter):
    return counter._secret

def who():
    return os.getuid(), os.path.exists(LABS), os.environ.get("RETROFIT_SANDBOX")
'''


class Counter:
    """A checks-side object: it stays in the grader; the student's code calls it back."""

    def __init__(self):
        self.count, self._secret = 0, "grader-only"

    def tick(self):
        self.count += 1
        return self.count


@pytest.fixture
def module(tmp_path):
    lab = make_lab(tmp_path)
    target = tmp_path / "mine.py"
    target.write_text(f"LABS = {str(lab.parent)!r}\n" + STUDENT, encoding="utf-8")
    yield open_target(target, lab, Sandbox(uid=sandbox_uid(), hide=[str(lab.parent)]))
    close_all()


def test_plain_values_cross_as_themselves(module):
    got = module.values()
    assert got["int"] == 2 ** 70 and np.isnan(got["nan"]) and got["tuple"] == (1, "a") and got["list"] == [1.0, None]
    assert got["keys"] == {(1, 2): b"\x00"} and got["set"] == {3} and got["complex"] == 1 - 2j
    assert got["array"].dtype == np.int64 and got["array"].shape == (2, 3) and got["array"][1, 2] == 5
    assert type(got["f32"]) is np.float32 and got["f32"] == 0.25
    assert got["machine"] == load_machine("chivu-lathe") and got["command"] == PMov((("X", 1.25),))


def test_other_objects_stay_with_the_student_and_compare_only_to_themselves(module):
    state = module.state()
    assert state.x == 1.5 and "State" in repr(state)
    assert (module.cheat() == 5) is False and module.cheat() != 5
    with pytest.raises(TypeError, match="not an array of numbers"):
        np.asarray(module.objects())


def test_the_students_code_calls_back_into_the_checks_objects_but_not_their_insides(module):
    counter = Counter()
    assert module.call_back(counter, 3) == [1, 2, 3] and counter.count == 3
    with pytest.raises(AttributeError):
        module.peek(counter)


@pytest.mark.skipif(not ROOT, reason="the uid change needs root")
def test_as_root_the_student_runs_as_its_own_uid_and_sees_no_labs(module):
    uid, sees_labs, how = module.who()
    assert uid == sandbox_uid() and uid != 0 and sees_labs is False and how == "namespace"


def test_without_root_the_sandbox_still_runs_the_file_in_its_own_process(tmp_path):
    lab = make_lab(tmp_path)
    target = tmp_path / "mine.py"
    target.write_text(f"LABS = {str(lab.parent)!r}\n" + STUDENT, encoding="utf-8")
    module = open_target(target, lab, Sandbox(uid=None, isolate=False))
    try:
        uid, _, how = module.who()
        assert uid == os.geteuid() and how == "plain"
    finally:
        close_all()


@pytest.mark.parametrize("body", [
    b"\x80\x04K\x01.",                                                        # a pickle
    b'{"k": "ok", "v": {"$": "dc", "cls": "os:system", "v": []}}',           # not retrofit's
    b'{"k": "ok", "v": {"$": "dc", "cls": "retrofit.lab.core:Lab", "v": [["path", "/"], ["x", 1]]}}',
    b'{"k": "ok", "v": {"$": "nd", "dt": "|O8", "sh": [1], "v": "AAAAAAAAAAA="}}',   # object arrays
    b'{"k": "ok", "v": {"$": "nd", "dt": "<i8", "sh": [1000000], "v": "AAAAAAAAAAA="}}',
    b'{"k": "ok", "v": {"__class__": "x"}}',
    b'{"k": "ok", "v": {"$": "exec", "v": "import os"}}',
], ids=["pickle", "foreign-class", "unknown-field", "object-dtype", "short-array", "plain-object", "unknown-tag"])
def test_what_the_student_sends_back_is_decoded_strictly(body):
    with pytest.raises(labwire.WireError):
        labwire.decode(body, {})


def test_a_message_bigger_than_the_limit_is_refused_before_it_is_read():
    reader = labwire.Reader()
    reader.feed((labwire.MAX_MESSAGE + 1).to_bytes(4, "big") + b"J")
    with pytest.raises(labwire.WireError, match="bytes"):
        reader.next()


def _git(cwd, *args):
    subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True,
                   env={**os.environ, "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
                        "GIT_COMMITTER_EMAIL": "t@t"})


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_export_hands_out_the_committed_stub_and_warns_when_the_working_file_differs(tmp_path):
    lab_path = make_lab(tmp_path / "repo")
    _git(tmp_path / "repo", "init", "-q")
    _git(tmp_path / "repo", "add", "-A")
    _git(tmp_path / "repo", "commit", "-qm", "labs")
    (lab_path / "student.py").write_text(RIGHT, encoding="utf-8")      # the teacher tried the lab here
    warnings = []
    written = export_lab(find_lab(lab_path.parent, "01"), tmp_path / "out", warn=warnings.append)
    exported = tmp_path / "out" / "01_adder" / "student.py"
    assert exported in written and exported.read_text(encoding="utf-8") == STUB
    assert len(warnings) == 1 and "differs from the committed stub" in warnings[0]


def test_export_outside_git_refuses_a_student_file_without_todos(tmp_path):
    lab_path = make_lab(tmp_path)
    (lab_path / "student.py").write_text(RIGHT, encoding="utf-8")
    with pytest.raises(ConfigError, match="no TODO is left"):
        export_lab(find_lab(lab_path.parent, "01"), tmp_path / "out")


def test_grade_with_a_relative_labs_folder(tmp_path, monkeypatch, capsys):
    make_lab(tmp_path)
    for name, text in (("ana", RIGHT), ("bob", STUB)):
        (tmp_path / "class" / name).mkdir(parents=True)
        (tmp_path / "class" / name / "student.py").write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert main(["lab", "grade", "01", "class", "--labs", "labs", "--check-seconds", "2"]) == 0
    rows = {r["student"]: r for r in csv.DictReader((tmp_path / "class" / "grades.csv").open(encoding="utf-8"))}
    assert (rows["ana"]["points"], rows["bob"]["points"], rows["bob"]["TODO 1"]) == ("4", "0", "not written")
    assert json.loads((tmp_path / "class" / "grades.json").read_text())["students"][0]["todos"] == {
        "TODO 1": "ok", "TODO 2": "ok"}


def test_the_score_is_capped_by_the_graders_own_count(tmp_path):
    from retrofit.lab.grade import Grade, _read_result
    forged = tmp_path / "result.json"
    forged.write_text(json.dumps({"checks": [{"title": "TODO 1: x", "status": "passed", "points": 1000,
                                              "max_points": 1}]}), encoding="utf-8")
    checks, note = _read_result(forged)
    assert checks == [] and "no usable result" in note
    many = [{"title": f"TODO 1: {i}", "status": "passed", "points": 1, "max_points": 1} for i in range(9)]
    assert Grade("x", checks=many, max_points=4).points == 4


SUBREAPER = '''
import os, subprocess, sys, time
from retrofit.lab.process import become_subreaper, children_of, kill_children
assert become_subreaper()
double_fork = "import os, time\\nif os.fork() == 0:\\n    os.setsid()\\n    if os.fork() == 0:\\n        time.sleep(300)\\n    os._exit(0)\\n"
subprocess.run([sys.executable, "-c", double_fork], check=True)
for _ in range(6000):                 # the grandchild, orphaned twice, is handed to this process
    if children_of(os.getpid()):
        break
    time.sleep(0.01)
orphans = children_of(os.getpid())
print(len(orphans), kill_children(), len(children_of(os.getpid())), all(not os.path.exists(f"/proc/{p}") for p in orphans))
'''


def test_without_root_a_detached_grandchild_is_handed_to_the_checker_and_killed():
    done = subprocess.run([sys.executable, "-c", SUBREAPER], capture_output=True, text=True, timeout=120)
    orphans, killed, left, gone = done.stdout.split()       # the orphans may include the middle one, exited
    assert int(orphans) >= 1 and killed == orphans and (left, gone) == ("0", "True"), done.stderr
