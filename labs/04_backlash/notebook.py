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
# # Backlash: measure the dead band, then compensate it
#
# **Goal.** Measure the play of each lead screw of the simulated lathe the way you would on the
# real one — with a dial indicator on the carriage while the motor reverses one step at a time —
# then give the controller the clearance you measured and show the carriage error before and after.
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
targets = lab.dial_targets(lathe, "X")
readings = lab.dial_readings(lathe, "X", targets)
print("dial readings (step, mm):", readings[-4:])
print("X dead band:", lab.dead_band_mm(lathe, "X", readings), "mm")

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
# The same checks as `retrofit lab check 04`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "04"), target=target_path(HERE))):
    print(line)
