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
# # The tool changer: X, Y, Z and the carousel during a tool change
#
# **Goal.** Follow a T3 → T7 change on the simulated desktop mill: where each pocket sits on the
# carousel, and X, Y, Z and the carousel's angle over time, taken from what the simulated axes
# really did. Show that the carousel turns only when the spindle is clear of the tools, and that
# the change ends with T7 in the spindle and T3 back in its own pocket.
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
geometry = lab.atc_of(load_machine(lab.MACHINE)).sim
for pocket in (3, 7):
    print(f"pocket {pocket}: {lab.pocket_angle_deg(geometry, pocket):.1f} deg on the carousel, "
          f"carousel axis at {lab.carousel_position(geometry, pocket):.3f}")

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
# The same checks as `retrofit lab check 08`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "08"), target=target_path(HERE))):
    print(line)
