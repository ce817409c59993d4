# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # The lathe paper's circle: commanded path and carriage path
#
# **Goal.** Compute the paper's 100-point circle in motor steps, drive the simulated lathe round
# it with the paper's position-error loop, and see where the carriage really went — with and
# without backlash compensation.
#
# The whole handout is `README.md` beside this notebook. Work in `student.py`; this notebook
# imports it afresh each time you run the cell below, so save the file, then re-run.

# %%
# The file under study: student.py, or what RETROFIT_LAB_TARGET names ("solution" runs the reference).
from pathlib import Path

from IPython.display import Image, display

from retrofit.machine.config import load_machine
from retrofit.lab.core import load_module, target_path

HERE = Path.cwd()
lab = load_module(target_path(HERE))
print("working on", target_path(HERE).name)

# %% [markdown]
# ## Try your functions
# Small calls first: predict each answer before you run the cell.

# %%
lathe = load_machine(lab.MACHINE)
print("point 0:", lab.calc_next_input(0, 40.0, 50.0), " point 25:", lab.calc_next_input(25, 40.0, 50.0))
targets = lab.circle_targets(lathe)
print(len(targets), "targets; the first three:", targets[:3])

# %% [markdown]
# ## The plots
# `main()` runs the whole lab with your functions and saves its plots; they show below. Before
# you run it, write down what you expect to see (the handout's questions), then compare.

# %%
for written in lab.main(HERE / "out"):
    if written.suffix == ".png":
        display(Image(filename=str(written)))
    else:
        print("also wrote", written.name)

# %% [markdown]
# ## Check your work
# The same checks as `retrofit lab check 01`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "01"), target=target_path(HERE))):
    print(line)
