#!/usr/bin/env python3
"""Plots for an ndsid report folder: EG history (with 1-sigma bars) and data coverage
(g-g diagram against Kamm's circle, v-a_y). Reads the CSV files `ndsid replay` writes."""
import csv
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def plot_history(folder: Path):
    rows = [r for r in read_csv(folder / "eg_history.csv") if r["valid"] == "1"]
    if not rows:
        return
    h = [float(r["gated_hours"]) for r in rows]
    eg = [float(r["eg_deg_per_g"]) for r in rows]
    se = [float(r["eg_se_deg_per_g"]) for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.errorbar(h, eg, yerr=se, fmt="o-", capsize=3, label="EG ± 1σ")
    ax.set_xlabel("gated driving [h]")
    ax.set_ylabel("self-steering gradient EG [deg/g]")
    ax.set_title("EG against accumulated data (adequacy)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(folder / "eg_history.png", dpi=110)
    plt.close(fig)


def plot_coverage(folder: Path):
    rows = read_csv(folder / "coverage.csv")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, name, xlabel, width in ((axes[0], "gg", "a_x [m/s²]", 0.5), (axes[1], "v_ay", "v [m/s]", 2.5)):
        pts = [r for r in rows if r["histogram"] == name]
        if pts:
            xs = [float(r["x_lo"]) + width / 2 for r in pts]
            ys = [float(r["y_lo"]) + 0.25 for r in pts]
            cs = [math.log10(float(r["count"])) for r in pts]
            sc = ax.scatter(xs, ys, c=cs, marker="s", s=30, cmap="viridis")
            fig.colorbar(sc, ax=ax, label="log10(samples)")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("a_y [m/s²]")
        ax.grid(True, alpha=0.3)
    t = [i * 2 * math.pi / 200 for i in range(201)]
    for mu in (0.4, 1.0):
        axes[0].plot([mu * 9.81 * math.cos(a) for a in t], [mu * 9.81 * math.sin(a) for a in t], "--",
                     label=f"Kamm's circle μ={mu}")
    axes[0].set_aspect("equal")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("g-g diagram (gated samples)")
    axes[1].set_title("speed vs lateral acceleration")
    fig.tight_layout()
    fig.savefig(folder / "coverage.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    folder = Path(sys.argv[1])
    plot_history(folder)
    plot_coverage(folder)
