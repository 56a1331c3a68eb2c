"""The seed RLC loop from Python, notebook style: run it, build it from parts, sweep its resistance.

Writes docs/figures/python_seed_sweep.png (needs matplotlib):

    python examples/python/seed_rlc_sweep.py
"""

# %% Run the netlist and compare with the exact charge.
import pathlib

import numpy as np

import dirac

REPO = pathlib.Path(__file__).resolve().parents[2]
trajectory = dirac.run(REPO / "examples" / "netlists" / "seed_rlc.cir", method="gauss2")
print(trajectory)
print(trajectory.summary)
L, C, R = 0.75, 3.0, 0.1
gamma, omega = R / (2 * L), np.sqrt(1 / (L * C) - (R / (2 * L)) ** 2)
t = trajectory.t
exact_v = np.exp(-gamma * t) * (np.cos(omega * t) + gamma / omega * np.sin(omega * t))
print(f"max |v(1) - exact| with gauss2: {np.max(np.abs(trajectory['v(1)'] - exact_v)):.2e}")

# %% The same loop built from parts, with the scene format's names.
loop = dirac.System(h=0.05, t_end=50.0)
loop.part("C1", "capacitor", c=3.0, q0=3.0)  # q = C·V for the netlist's IC = 1 V
loop.part("L1", "inductor", l=0.75)
loop.part("R1", "resistor", r=0.1)
loop.node("n1", "+L1.i", "-R1.i")
loop.node("n2", "+R1.i", "-C1.i")
loop.node("n3", "+C1.i", "-L1.i")
loop.record(["C1.q", "L1.i"], energy=True)
model = loop.build()
for c in model.compare(t_end=10.0):
    print(f"{c.execution:<17} {c.max_abs_deviation if c.max_abs_deviation is not None else c.note}")

# %% Sweep the resistance: the charge left after 10 s and the largest current.
table = dirac.sweep(
    model,
    {"R1.r": np.geomspace(0.01, 3.0, 60)},
    reduce=["final(C1.q)", "peak(L1.i)", "final(energy)"],
    t_end=10.0,
)
print(table.head())

# %% Figure: three trajectories and the sweep.
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
for r in (0.1, 0.5, 2.0):
    run = model.with_parameters({"R1.r": r}).run(t_end=20.0)
    left.plot(run.t, run["C1.q"], label=f"R = {r} Ω")
left.set_xlabel("t [s]")
left.set_ylabel("capacitor charge q [C]")
left.set_title("seed RLC loop from parts (midpoint, h = 0.05)")
left.legend()
right.semilogx(table["R1.r"], table["final(energy)"], "o-", ms=3)
right.axvline(2 * np.sqrt(0.75 / 3.0), color="grey", ls=":", label="critical R = 2√(L/C)")
right.set_xlabel("R1.r [Ω]")
right.set_ylabel("energy left at t = 10 s [J]")
right.set_title("dirac.sweep over 60 resistances")
right.legend()
fig.tight_layout()
out = REPO / "docs" / "figures" / "python_seed_sweep.png"
fig.savefig(out, dpi=110)
print(f"wrote {out}")
