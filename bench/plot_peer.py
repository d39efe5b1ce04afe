#!/usr/bin/env python3
"""Log-log plots of relMSE against seconds from `pathlight bench --peer`'s CSV series.

    python3 bench/plot_peer.py OUT SCENE...

reads OUT/<scene>/{pathlight-cpu,pathlight-cpu-independent,pathlight-cpu-{bdpt,mlt,sppm},pathlight-gpu,mitsuba,
mitsuba-ldsampler,pbrt-{bdpt,mlt,sppm}}.csv (those present) and writes OUT/peer.svg (one
panel per scene). An unbiased renderer's relMSE falls as 1/t: a line of slope -1, shown
dotted through each series' last point; a series below another at equal time is ahead.
"""

import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SERIES = [
    ("pathlight-cpu.csv", "pathlight CPU backend", "tab:blue", "o-"),
    ("pathlight-cpu-independent.csv", "pathlight CPU backend, independent sampler", "tab:blue", "x:"),
    ("pathlight-cpu-bdpt.csv", "pathlight CPU backend, bdpt", "tab:purple", "o-"),
    ("pathlight-cpu-mlt.csv", "pathlight CPU backend, mlt", "tab:brown", "o-"),
    ("pathlight-cpu-sppm.csv", "pathlight CPU backend, sppm", "tab:cyan", "o-"),
    ("pathlight-gpu.csv", "pathlight GPU backend (this machine)", "tab:orange", "o-"),
    ("mitsuba.csv", "Mitsuba 3", "tab:green", "o-"),
    ("mitsuba-ldsampler.csv", "Mitsuba 3, ldsampler", "tab:green", "x:"),
    ("pbrt-bdpt.csv", "pbrt-v4 bdpt (against its own converged image)", "tab:red", "o-"),
    ("pbrt-mlt.csv", "pbrt-v4 mlt (against its own converged image)", "tab:red", "x--"),
    ("pbrt-sppm.csv", "pbrt-v4 sppm (against its own converged image)", "tab:pink", "x--"),
    # Measured on another machine (`--pathlight-only`), drawn for scale, not compared.
    ("pathlight-h100.csv", "pathlight GPU backend, H100 (other machine)", "tab:gray", "s--"),
]


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return [float(r["seconds"]) for r in rows], [float(r["relmse"]) for r in rows], [int(r["spp"]) for r in rows]


def main():
    out, scenes = sys.argv[1], sys.argv[2:]
    fig, axes = plt.subplots(1, len(scenes), figsize=(4.2 * len(scenes), 4.0), squeeze=False)
    for ax, scene in zip(axes[0], scenes):
        for name, label, colour, style in SERIES:
            path = os.path.join(out, scene, name)
            if not os.path.exists(path):
                continue
            t, e, spp = read(path)
            ax.loglog(t, e, style, color=colour, label=label, markersize=3)
            ax.loglog([t[-1] / 100, t[-1]], [e[-1] * 100, e[-1]], ":", color=colour, linewidth=0.8)
            ax.annotate(f"{spp[-1]} spp", (t[-1], e[-1]), fontsize=7, color=colour, xytext=(3, 3), textcoords="offset points")
        ax.set_title(scene, fontsize=10)
        ax.set_xlabel("seconds")
        ax.grid(True, which="both", linewidth=0.3)
    axes[0][0].set_ylabel("relMSE against the reference")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "peer.svg"))
    print(f"wrote {os.path.join(out, 'peer.svg')}")


if __name__ == "__main__":
    main()
