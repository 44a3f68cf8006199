"""nnm from Python, in cells (`# %%`: run them one by one in VS Code, Spyder or Jupyter, or the
whole file with `python examples/python/quickstart.py [OUT_DIR]`; figures go to OUT_DIR,
default out/python-quickstart).

Install first: `pip install ./crates/nnm-py` (or run `scripts/test-all`, which installs it in
.venv), plus scipy, matplotlib and pandas for the parts that use them.
"""

# %% Set-up: draw to files when there is no display.
import os
import sys
from pathlib import Path

import matplotlib

if not os.environ.get("DISPLAY") and "ipykernel" not in sys.modules:
    matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import scipy.sparse as sp

import nnm
from nnm import plot

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/python-quickstart")
out.mkdir(parents=True, exist_ok=True)

# %% 1. The Duffing oscillator x'' + x + x^3 = 0: its backbone to twice the linear frequency.
duffing = nnm.duffing(natural_frequency=1.0, cubic=1.0)
branch = nnm.backbone(duffing, mode=0, frequency_shift_max=1.0, tolerance=1e-10)
print(branch)
print(branch.to_pandas()[["energy", "frequency_rad_s", "stable"]].tail(3))

# %% 2. Your own model: M and K as numpy arrays (or scipy.sparse), springs as elements.
#    Two masses on springs, a cubic spring from the first to ground (the paper's 2-DOF system).
M = np.eye(2)
K = np.array([[2.0, -1.0], [-1.0, 2.0]])
model = nnm.Model(M, K, nonlinear=[nnm.Cubic(dofs=[0], coefficient=0.5)])
modes = nnm.modes(model)
print("linear frequencies (rad/s):", modes.frequencies)
in_phase = nnm.backbone(model, mode=0, energy_max=100.0)
out_of_phase = nnm.backbone(model, mode=1, energy_max=100.0)
for e in in_phase.events:
    print(f"{e.kind} at E = {e.energy:.6g}, f = {e.frequency:.6g} rad/s")

# The family that crosses the in-phase one at its branch point (nnm run's `start = {...}`).
crossing = in_phase.switch(0, energy_max=100.0)
print(crossing, "switched with the", crossing.switched_from["phase"], "phase condition")

ax = plot.fep([in_phase, out_of_phase, crossing], labels=["in phase", "out of phase", "switched"])
ax.figure.savefig(out / "two-dof-fep.png", dpi=120)

# %% 3. The same model sparse: scipy matrices stay sparse inside the library.
sparse = nnm.Model(sp.csr_array(M), sp.csr_array(K), nonlinear=[nnm.Cubic([0], 0.5)])
same = nnm.backbone(sparse, mode=0, energy_max=100.0)
print("sparse input, same branch:", np.array_equal(same.frequency, in_phase.frequency))

# %% 4. A motion over one period, at the last stable point before the branch point.
i = int(np.flatnonzero(in_phase.stable)[-1])
motion = in_phase.motion(i, samples=200)
ax = plot.time_series(motion)
ax.set_title(f"in-phase NNM at E = {in_phase.energy[i]:.3g}")
ax.figure.savefig(out / "two-dof-motion.png", dpi=120)

# %% 5. The paper's bladed disk: (n, d) labels, and the localizing (1,14) family.
disk = nnm.bladed_disk()
disk_modes = nnm.modes(disk)
print(disk_modes.to_pandas().head(6))
localizing = nnm.backbone(disk, mode=(1, 14), energy_max=1000.0, frequency_shift_max=0.25)
print(localizing)
blades = localizing.displacement0[:, 1::2]
share = (blades**2).max(axis=1) / (blades**2).sum(axis=1)
print(f"largest blade's share of the blades' x0^2: {share[0]:.3f} at the start, {share[-1]:.3f} at the end")

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
localizing.plot(ax=left)
plot.mode_shape(blades[0], ax=right, label="first point")
plot.mode_shape(blades[-1], ax=right, label="last point")
right.set_xlabel("blade")
fig.tight_layout()
fig.savefig(out / "bladed-disk-1-14.png", dpi=120)

# %% 6. Failures keep what was computed: a step that fails at the minimum step size.
try:
    nnm.backbone(duffing, mode=0, energy_max=100.0, max_iterations=1, min_step=0.05, tolerance=1e-10)
except nnm.ContinuationError as error:
    print(f"stopped: {error} — {len(error.branch)} points kept, up to E = {error.branch.energy[-1]:.3g}")

print(f"figures in {out}/")
