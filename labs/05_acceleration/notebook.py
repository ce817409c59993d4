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
# # Acceleration and lost steps
#
# **Goal.** Find how steep a velocity ramp the engraver's X stepper can follow before it loses
# steps: from its torque curve on paper, and by experiment in the simulator. Compare the
# trapezoidal ramp with the exponential ramp of the engraver paper.
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
engraver = load_machine(lab.MACHINE_FILE)
for speed in (10.0, 40.0, 80.0):
    print(f"ramp limit at {speed} mm/s: {lab.motor_ramp_limit(engraver, speed):.0f} mm/s^2")

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
# The same checks as `retrofit lab check 05`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "05"), target=target_path(HERE))):
    print(line)
