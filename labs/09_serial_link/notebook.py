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
# # The serial link: framing, CRC, NAK and resend on a noisy line
#
# **Goal.** Build the frames of the turning-machine controller's serial link by hand, then measure
# on a simulated noisy cable what gets lost without a protocol and what the protocol guarantees.
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
# Predict first: how long is the frame of a 3-byte payload holding one SOF byte?

# %%
print("stuffed 01 7e 7d:", lab.stuff(bytes((0x01, 0x7E, 0x7D))).hex(" "))
print("frame(5, 01 7e 02):", lab.frame(5, bytes((0x01, 0x7E, 0x02))).hex(" "))
caught, tried = lab.crc_catches(5, bytes((0x01, 0x7E, 0x02)))
print(f"single-bit flips refused: {caught} of {tried}")
delivered, stats = lab.run_protocol(lab.moves(20), 0.02)
print(f"with the protocol at 2 % flipped bytes: {len(delivered)} of 20 delivered, {stats.resends} resends")

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
# The same checks as `retrofit lab check 09`: one line per check.

# %%
from retrofit.lab.core import check_lab, find_lab, result_lines

for line in result_lines(check_lab(find_lab(HERE.parent, "09"), target=target_path(HERE))):
    print(line)
