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
# # The same motion three ways: a tick loop, gateware, a firmware
#
# **Goal.** Write the engraver FPGA's delay and width counters in Amaranth HDL, turn a run's
# pins into the records 004's processor sends, and prove your gateware's pins equal to the
# Python tick loop's at every tick.
#
# The whole handout is `README.md` beside this notebook. Work in `student.py`; this notebook
# imports it afresh each time you run the cell below, so save the file, then re-run.

# %%
# The file under study: student.py, or what RETROFIT_LAB_TARGET names ("solution" runs the reference).
from pathlib import Path

from IPython.display import Image, display

from retrofit.lab.core import load_module, target_path

HERE = Path.cwd()
lab = load_module(target_path(HERE))
print("working on", target_path(HERE).name)

# %% [markdown]
# ## Try your counter
# Three records: a turn at tick 3, a pulse of width 4 at tick 10, another at tick 20. Predict the
# pins before you run the cell.

# %%
got = lab.run_gateware([(3, 1, 0), (7, 1, 4), (10, 1, 4)], 28)
print("dir :", "".join(str(v) for v in got["dir"]))
print("step:", "".join(str(v) for v in got["step"]))
print("records taken at ticks", got["taken"])

# %% [markdown]
# ## The plots
# `main()` runs the whole lab with your functions and saves its plots; they show below.

# %%
for written in lab.main(HERE / "out"):
    display(Image(filename=str(written)))

# %% [markdown]
# ## Check your work
# The same checks as `retrofit lab check 13`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "13"), target=target_path(HERE))):
    print(line)
