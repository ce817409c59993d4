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
# # From G-code to motion: modal state and the G81 drilling cycle
#
# **Goal.** Turn a part program into the straight moves a machine makes: read the words of each
# block, carry the modal state, and expand the G81 drilling cycle — worked by hand first.
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
# Predict first: the moves of one hole at X10 Y5 from Z5, with R2 and Z-3, in G99.

# %%
print(lab.parse_words("G81 X10 Y5 Z-3 R2"))
state = lab.State(motion="G81", retract_to_start=False, feed=100.0, z=5.0, r=2.0, depth=-3.0)
for move in lab.g81_moves(state, 10.0, 5.0):
    print(move)
text = (HERE / "programs" / "drill_g98.ngc").read_text()
print(text)
for move in lab.interpret(text):
    print(move)

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
# The same checks as `retrofit lab check 10`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "10"), target=target_path(HERE))):
    print(line)
