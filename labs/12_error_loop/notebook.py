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
# # The position-error loop with backlash: the carriage on a screw with play
#
# **Goal.** Write the lathe paper's *EvaluateEroare* with its backlash compensation, and drive
# the simulated lathe, whose lead screws have a real dead band, with it.
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
# One reversal of X on the lathe: 6 steps out, then back to 2. Predict the readout (the
# instantaneous position each time it changes) before you run the cell.

# %%
lathe = load_machine(lab.MACHINE)
print("turn(10, -1, +1, 4) ->", lab.turn(10, -1, 1, 4))
print("evaluate_axis(2, 6, +1, 4, True) ->", lab.evaluate_axis(2, 6, 1, 4, True))
run = lab.run_loop(lathe, [[6, 0], [2, 0]], True)
print("reached at ticks", run["reached"], "; run ends at tick", run["end_tick"])
print("readout:", [(t, p) for t, name, p in run["readout"] if name == "X"])
print("carriage at the targets (mm):", lab.carriages(lathe, run))

# %% [markdown]
# ## The plots
# `main()` runs the zigzag compensated and not, and saves its plots; they show below.

# %%
for written in lab.main(HERE / "out"):
    if written.suffix == ".png":
        display(Image(filename=str(written)))
    else:
        print("also wrote", written.name)

# %% [markdown]
# ## Check your work
# The same checks as `retrofit lab check 12`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "12"), target=target_path(HERE))):
    print(line)
