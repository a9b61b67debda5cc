"""Mourya 2017 Fig. 2 from Python: the spiral tracked by six receivers.

(a) the eq. (5) (synchronous) gossip with the exact GTRS prox against the
    relaxed prox that drops the quadratic constraint of eq. (12): the
    estimate's coordinates against the sample index k, beside the truth;
(b) the true track and the tracks of the sync (eq. 5) and async (eq. 11)
    algorithms, 50 iterations between samples, gamma = 2e-8.

    pip install ./python matplotlib
    python examples/python/spiral.py [OUT_DIR]

Writes fig2a.png and fig2b.png (default: results/python-spiral/) and prints
the RMSE after the burn-in of each run.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import sonarnet  # noqa: E402

out = Path(sys.argv[1] if len(sys.argv) > 1 else "results/python-spiral")
out.mkdir(parents=True, exist_ok=True)
sc = sonarnet.Scenario.builtin("mourya2017-spiral")

# (a) eq. (5) with and without the quadratic constraint.
runs = {
    solver: sc.with_overrides({"algorithm.local_solver": solver}).run(engine="inprocess", mode="sync", progress=False)
    for solver in ("gtrs", "relaxed")
}
fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharex=True)
for ax, axis in zip(axes, ("x", "y")):
    truth = runs["gtrs"].track
    ax.plot(truth["sample"], truth[f"true_{axis}"], "k-", label="truth")
    for solver, run in runs.items():
        ax.plot(run.track["sample"], run.track[f"est_{axis}"], label=f"eq. (5), {solver} prox")
    ax.set_xlabel("sample k")
    ax.set_ylabel(f"{axis} (m)")
axes[0].legend()
fig.suptitle("Mourya 2017 Fig. 2(a): the quadratic constraint of eq. (12)")
fig.tight_layout()
fig.savefig(out / "fig2a.png", dpi=120)

# (b) the tracks of eq. (5) and eq. (11).
tracks = {mode: sc.run(engine="inprocess", mode=mode, progress=False) for mode in ("sync", "async")}
fig, ax = plt.subplots(figsize=(6, 6))
t = tracks["sync"].track
ax.plot(t["true_x"], t["true_y"], "b*-", ms=3, label="true track")
for mode, run in tracks.items():
    ax.plot(run.track["est_x"], run.track["est_y"], label=f"{mode} (eq. {5 if mode == 'sync' else 11})")
ax.set_aspect("equal")
ax.set_xlabel("x (m)")
ax.set_ylabel("y (m)")
ax.legend()
ax.set_title("Mourya 2017 Fig. 2(b)")
fig.tight_layout()
fig.savefig(out / "fig2b.png", dpi=120)

burn_in = 10
for name, run in [*(("sync " + k, r) for k, r in runs.items()), *(("track " + k, r) for k, r in tracks.items())]:
    err = run.track["error"][run.track["sample"] >= burn_in]
    print(f"{name:<14} rmse after burn-in {(err ** 2).mean() ** 0.5:8.2f} m")
print(f"figures in {out}")
