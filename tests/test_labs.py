"""The labs: every reference solution runs headless, writes its plots and passes its checks; every
untouched student file fails a check with a message a student can act on; the lab commands work."""

import ast
import math
import subprocess
import sys
from pathlib import Path

import pytest

from retrofit.cli import main
from retrofit.errors import ConfigError
from retrofit.lab.core import (
    TARGET_ENV,
    CheckFailed,
    check_lab,
    explain,
    find_lab,
    labs_dir,
    list_labs,
    load_module,
    pyplot,
    result_lines,
)

ROOT = Path(__file__).resolve().parent.parent / "labs"
LABS = list_labs(ROOT)
IDS = [lab.path.name for lab in LABS]
EIGHT = {"01_circle", "02_step_pulses", "03_bresenham_dda", "04_backlash", "05_acceleration", "06_threading",
         "07_position_loop", "08_tool_changer"}
PNG = b"\x89PNG\r\n\x1a\n"


def test_the_eight_labs_are_there_with_their_four_files():
    assert EIGHT <= set(IDS)
    for lab in LABS:
        for name in ("README.md", "student.py", "solution.py", "checks.py"):
            assert (lab.path / name).is_file(), f"{lab.path.name} has no {name}"
        assert lab.title and not lab.title.startswith(lab.number)


def figure_defects(fig) -> list[str]:
    """What a reader would miss on a figure: a title, the axes' labels."""
    defects = []
    suptitle = fig._suptitle.get_text() if fig._suptitle is not None else ""
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_label() != "<colorbar>"]
    for k, ax in enumerate(panels):
        twin = any(o.get_position().bounds == ax.get_position().bounds for o in panels[:k])
        if not (ax.get_title() or suptitle or twin):     # a twin y axis shares its panel's title
            defects.append(f"panel {k} has no title")
        if ax.name == "polar":
            continue
        named_ticks = any(t.get_text() and not t.get_text().lstrip("−-").replace(".", "").isdigit()
                          for t in ax.get_yticklabels())
        if not (ax.get_ylabel() or named_ticks):
            defects.append(f"panel {k} has no y label")
    if not any(ax.get_xlabel() for ax in panels if ax.name != "polar") and any(ax.name != "polar" for ax in panels):
        defects.append("no x label")
    return defects


@pytest.mark.slow          # every lab's whole solution with its plots: long runs
@pytest.mark.parametrize("lab", LABS, ids=IDS)
def test_solution_runs_headless_and_writes_its_plots(lab, tmp_path, monkeypatch):
    """Every plot is saved as a PNG, headless, with a title and labelled axes."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    pyplot()
    module = load_module(lab.file(True))
    save, defects = module.save_figure, []

    def checked_save(fig, out_dir, name):
        defects.extend(f"{name}: {d}" for d in figure_defects(fig))
        return save(fig, out_dir, name)
    monkeypatch.setattr(module, "save_figure", checked_save)
    written = [Path(p) for p in module.main(tmp_path)]
    import matplotlib
    assert matplotlib.get_backend().lower() == "agg"
    pngs = [p for p in written if p.suffix == ".png"]
    assert len(pngs) >= 2, f"{lab.path.name}: main() should save its plots, wrote {written}"
    for path in pngs:
        assert path.parent == tmp_path and path.read_bytes()[:8] == PNG and path.stat().st_size > 15_000
    assert not defects, defects


def test_lathe_timing_title_counts_the_pulses_drawn_and_names_the_take_up(tmp_path, monkeypatch):
    module = load_module(find_lab(ROOT, "02").file(True))
    titles = []

    def keep(fig, out_dir, name):
        titles.append(fig.axes[0].get_title())
        return tmp_path / name
    monkeypatch.setattr(module, "save_figure", keep)
    machine = module.load_machine(module.MACHINE)
    signals, _ = module.lathe_signals(machine, [(3, 2), (0, 0)])
    module.plot_lathe_timing(signals, machine, tmp_path)
    rises = {axis: sum(1 for a, b in zip(signals[f"{axis}.step"], signals[f"{axis}.step"][1:]) if b and not a)
             for axis in ("X", "Z")}
    # X: 3 steps each way plus 4 steps (0.10 mm at 0.025 mm) of take-up; Z: 2 plus 4 (0.08 mm at 0.02 mm)
    assert rises == {"X": 14, "Z": 12}
    assert "X: 7 pulses out, 7 back" in titles[0] and "Z: 6 pulses out, 6 back" in titles[0]
    assert "backlash" in titles[0] and "X 4 (0.1 mm)" in titles[0]


def test_never_settling_gain_is_not_drawn_as_a_settling_time(tmp_path, monkeypatch):
    module = load_module(find_lab(ROOT, "07").file(True))
    figures = []
    monkeypatch.setattr(module, "save_figure", lambda fig, out_dir, name: figures.append(fig) or tmp_path / name)
    model = {0.1: (0.0, 161.0), 0.2: (1.8, 59.0)}
    sim = {0.1: (0.0, math.inf), 0.2: (0.0, 64.0)}
    module.plot_metrics(model, sim, 0.2, tmp_path)
    settle_ax = figures[0].axes[1]
    drawn = {(line.get_label(), float(x), float(y)) for line in settle_ax.get_lines()
             for x, y in zip(line.get_xdata(), line.get_ydata())}
    assert ("simulation", 0.2, 64.0) in drawn and ("model", 0.1, 161.0) in drawn
    assert not any(label == "simulation" and x == 0.1 for label, x, _ in drawn)
    arrow = [line for line in settle_ax.get_lines() if "not settled" in line.get_label()]
    assert arrow and list(arrow[0].get_xdata()) == [0.1] and "300 ms" in arrow[0].get_label()
    pyplot().close(figures[0])


@pytest.mark.parametrize("lab", LABS, ids=IDS)
def test_solution_passes_every_check(lab):
    results = check_lab(lab, solution=True)
    assert len(results) >= 4
    assert all(r.status == "passed" for r in results), "\n".join(result_lines(results))


@pytest.mark.parametrize("lab", LABS, ids=IDS)
def test_stub_fails_with_messages_a_student_can_act_on(lab):
    results = check_lab(lab, solution=False)
    failed = [r for r in results if r.status == "failed"]
    assert failed, f"{lab.path.name}: the untouched student.py passes every check"
    for r in failed:
        assert "Traceback" not in r.message and 'File "' not in r.message, r.message
        assert "TODO" in r.message and ("write " in r.message or "hint:" in r.message), r.message
    todo = next(r for r in failed if "not written yet" in r.message)
    assert "student.py line" in todo.message


@pytest.mark.parametrize("lab", LABS, ids=IDS)
def test_stub_and_solution_are_the_same_file_but_for_the_todos(lab):
    def names(path):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        return {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    student, solution = lab.file(False), lab.file(True)
    assert names(student) == names(solution)
    text = student.read_text(encoding="utf-8")
    assert text.count("raise NotImplementedError(\"TODO") >= 2 and "TODO 1" in text
    assert "TODO" not in solution.read_text(encoding="utf-8")


def test_the_checks_test_the_file_they_are_told_to(tmp_path):
    lab = find_lab(ROOT, "01")
    text = lab.file(True).read_text(encoding="utf-8").replace("math.trunc(", "round(")
    variant = tmp_path / "rounded.py"
    variant.write_text(text, encoding="utf-8")
    results = {r.title: r for r in check_lab(lab, target=variant)}
    failed = [r for r in results.values() if r.status == "failed"]
    assert failed and all(r.status == "passed" for t, r in results.items() if "TODO 3" in t)
    message = next(r.message for r in failed if "trunc does" in r.title)
    assert "expected: (37, 748)" in message and "your code gave: (38, 749)" in message
    assert "you rounded" in message


def test_explain_names_the_line_not_a_traceback(tmp_path):
    target = tmp_path / "student.py"
    target.write_text("def f():\n    return 1 / 0\n", encoding="utf-8")
    namespace = {}
    exec(compile(target.read_text(), str(target), "exec"), namespace)
    with pytest.raises(ZeroDivisionError) as info:
        namespace["f"]()
    text = explain(info.value, target)
    assert text.startswith("your code raised ZeroDivisionError") and "student.py line 2, in f" in text
    broken = SyntaxError("invalid syntax", (str(target), 7, 3, "x = = 1", 7, 4))
    assert explain(broken, target).startswith("student.py line 7 does not read as Python")
    failed = CheckFailed("calc_next_input(1)", expected="(37, 748)", got="(38, 749)", hint="trunc")
    assert str(failed).splitlines() == ["calc_next_input(1)", "expected: (37, 748)", "your code gave: (38, 749)",
                                        "hint: trunc"]


def test_labs_folder_is_found_and_can_be_chosen(tmp_path, monkeypatch):
    monkeypatch.delenv("RETROFIT_LABS", raising=False)
    assert labs_dir() == ROOT
    monkeypatch.setenv("RETROFIT_LABS", str(tmp_path))
    assert labs_dir() == tmp_path
    with pytest.raises(ConfigError, match="--labs .*no such folder"):
        labs_dir(tmp_path / "missing")
    with pytest.raises(ConfigError, match="no lab '99'.*01_circle"):
        find_lab(ROOT, "99")
    assert find_lab(ROOT, "circle") == find_lab(ROOT, "1") == find_lab(ROOT, "01_circle")


def test_lab_list_on_the_command_line():
    proc = subprocess.run([sys.executable, "-m", "retrofit.cli", "lab", "list"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    for name in ("01  circle", "05  acceleration", "06  threading", "07  position_loop", "08  tool_changer"):
        assert name in proc.stdout


def test_lab_check_prints_one_line_per_check(capsys, monkeypatch):
    monkeypatch.delenv(TARGET_ENV, raising=False)
    assert main(["lab", "check", "04", "--solution"]) == 0
    out = capsys.readouterr().out
    assert "checking" in out and "solution.py" in out and out.count("✓") >= 8 and "✗" not in out
    assert "checks pass; well done" in out
    assert main(["lab", "check", "02"]) == 1
    out = capsys.readouterr().out
    assert "✗ TODO 1" in out and "not written yet" in out and "Traceback" not in out
    assert "to fix" in out.splitlines()[-1]


def test_lab_run_saves_plots_or_says_what_to_write(tmp_path, capsys):
    assert main(["lab", "run", "02", "--solution", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert f"saved {tmp_path / 'counters.png'}" in out and (tmp_path / "lathe_steps.vcd").is_file()
    assert main(["lab", "run", "01", "--out", str(tmp_path / "stub")]) == 1
    out = capsys.readouterr().out
    assert "student.py stopped: not written yet: TODO" in out and "retrofit lab check 01" in out


def test_unknown_labs_folder_is_an_error(tmp_path, capsys):
    assert main(["lab", "list", "--labs", str(tmp_path / "nowhere")]) == 2
    assert "no such folder" in capsys.readouterr().err
    assert main(["lab", "check", "99", "--labs", str(ROOT)]) == 2
    assert "labs: 01_circle" in capsys.readouterr().err


def test_a_labs_checks_run_from_its_folder_leave_nothing_there(tmp_path, monkeypatch):
    """A student runs the checks from the lab's folder (the notebooks do too): the folder is as
    it was afterwards, but for what the lab writes into out/ (pytest-benchmark's plugin, loaded
    by the checks' pytest, once left a .benchmarks folder in every lab)."""
    import shutil
    copy = tmp_path / "labs" / LABS[0].path.name
    shutil.copytree(LABS[0].path, copy, ignore=shutil.ignore_patterns(".*", "__pycache__"))
    before = {p.name for p in copy.iterdir()}
    monkeypatch.chdir(copy)
    lab = next(lab for lab in list_labs(copy.parent) if lab.number == LABS[0].number)
    results = check_lab(lab, solution=True)
    assert results and all(r.status == "passed" for r in results), results
    assert {p.name for p in copy.iterdir()} - {"out"} == before - {"out"}
