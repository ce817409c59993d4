"""Every lab opens as a Jupyter notebook: a jupytext percent-format ``notebook.py`` that executes
headless against the reference solution, shows the lab's plots inline and prints the checks."""

from pathlib import Path

import pytest

from retrofit.lab.core import TARGET_ENV, list_labs

from tests import soak

ROOT = Path(__file__).resolve().parent.parent / "labs"
LABS = list_labs(ROOT)
IDS = [lab.path.name for lab in LABS]


@pytest.mark.parametrize("lab", LABS, ids=IDS)
def test_every_lab_has_a_paired_notebook(lab):
    jupytext = pytest.importorskip("jupytext")
    text = (lab.path / "notebook.py").read_text(encoding="utf-8")
    assert "formats: py:percent" in text
    notebook = jupytext.reads(text, fmt="py:percent")
    kinds = [cell.cell_type for cell in notebook.cells]
    assert kinds.count("markdown") >= 3 and kinds.count("code") >= 3
    assert notebook.cells[0].source.startswith(f"# {lab.title}")          # walks the handout
    assert "lab.main(" in text and "check_lab(" in text


@pytest.mark.slow
@pytest.mark.parametrize("lab", [LABS[k] for k in soak.parts(len(LABS), 7)],        # CI: 7 of them
                         ids=[IDS[k] for k in soak.parts(len(LABS), 7)])
def test_notebook_executes_headless_against_the_solution(lab, monkeypatch, tmp_path):
    jupytext = pytest.importorskip("jupytext")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv(TARGET_ENV, "solution")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    notebook = jupytext.read(lab.path / "notebook.py")
    nbclient.NotebookClient(notebook, timeout=240, kernel_name="python3",
                            resources={"metadata": {"path": str(lab.path)}}).execute()
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"]
    images = [o for o in outputs if o.output_type == "display_data" and "image/png" in o.get("data", {})]
    assert len(images) >= 2, f"{lab.path.name}: the plots should show inline"
    text = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert "working on solution.py" in text and "checks pass; well done" in text, text[-500:]
