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
# # The command set and its pipeline: prepare, execute, and a queue of three
#
# **Goal.** Write the controller of 002: the interpreter that prepares each command, the
# processor that executes the prepared moves one step cycle a tick, the queue of three and the
# scan for immediate commands.
#
# The whole handout is `README.md` beside this notebook. Work in `student.py`; this notebook
# imports it afresh each time you run the cell below, so save the file, then re-run.

# %%
# The file under study: student.py, or what RETROFIT_LAB_TARGET names ("solution" runs the reference).
from dataclasses import replace
from pathlib import Path

from IPython.display import Image, display

from retrofit.machine.config import load_machine
from retrofit.lab.core import load_module, target_path

HERE = Path.cwd()
lab = load_module(target_path(HERE))
print("working on", target_path(HERE).name)

# %% [markdown]
# ## Try your functions
# The host sends the first seven commands of the program without ticking. Predict each reply and
# the queue's length before you run the cell.

# %%
machine = load_machine(lab.MACHINE)
machine = replace(machine, motion=replace(machine.motion, lookahead=lab.LOOKAHEAD))
ctl = lab.new_controller(machine)
for text in lab.PROGRAM[:7]:
    ctl, reply = lab.submit(ctl, machine, text)
    print(f"{text:16} -> {reply:4}  queue {ctl['queue']}  prepared {[e['cmd'] for e in ctl['prepared']]}")
ctl, reply = lab.submit(ctl, machine, "RDST")
print("RDST ->", reply)

# %% [markdown]
# ## The plots
# `main()` streams the whole program through your controller and saves its plots; they show below.

# %%
for written in lab.main(HERE / "out"):
    if written.suffix == ".png":
        display(Image(filename=str(written)))
    else:
        print("also wrote", written.name)

# %% [markdown]
# ## Check your work
# The same checks as `retrofit lab check 11`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "11"), target=target_path(HERE))):
    print(line)
