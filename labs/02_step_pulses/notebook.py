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
# # Step pulses: the pulse-width and period counters
#
# **Goal.** Write the two counters that shape every step pulse of the lathe paper, prove them
# equal to retrofit's step generator tick by tick, and read a timing diagram of the lathe's step
# and direction pins.
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
counters = lab.PulseCounters(2, 3)          # 2 ticks high, 3 ticks low
bits = lab.timer_ticks(counters, [True] * 3 + [False] * 12)
print("step bit tick by tick:", "".join(str(int(b)) for b in bits))

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
# The same checks as `retrofit lab check 02`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "02"), target=target_path(HERE))):
    print(line)
