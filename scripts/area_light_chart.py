"""Draws docs/area_lights.csv (scripts/area_light_chart.sh) as RMS error against render time."""
import csv
import sys

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

rows = list(csv.DictReader(open(sys.argv[1])))
scenes = [("note", "the note's scene, 20 × 20 RectLights"), ("knot", "trefoil knot (19,200 triangles) on a floor")]
fig, axes = plt.subplots(1, 2, figsize=(12, 5))
colours = {1: "tab:blue", 2: "tab:orange", 4: "tab:green"}
for ax, (scene, title) in zip(axes, scenes):
    for pixel in (1, 2, 4):
        for method, style in (("uniform", "o-"), ("adaptive", "s--")):
            pts = [r for r in rows if r["scene"] == scene and int(r["pixel_samples"]) == pixel
                   and (r["method"] == method or (method == "adaptive" and r["method"] == "uniform"
                                                  and int(r["light_samples"]) < 8))]
            pts.sort(key=lambda r: int(r["light_samples"]))
            if not pts:
                continue
            x = [float(r["ms"]) for r in pts]
            y = [float(r["rms_levels"]) for r in pts]
            ax.plot(x, y, style, color=colours[pixel], label=f"{pixel}×{pixel} pixel, {method}", markersize=4)
            if method == "uniform":
                for r, xi, yi in zip(pts, x, y):
                    ax.annotate(r["light_samples"], (xi, yi), fontsize=7, xytext=(3, 3), textcoords="offset points")
        pts = [r for r in rows if r["scene"] == scene and r["method"] == "point" and int(r["pixel_samples"]) == pixel]
        for r in pts:
            ax.plot(float(r["ms"]), float(r["rms_levels"]), "x", color=colours[pixel], markersize=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.tick_params(axis="y", which="minor", labelsize=7)
    ax.set_xlabel("render time, ms (1 thread)")
    ax.set_ylabel("RMS error, levels of 255")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
axes[0].legend(fontsize=7, title="labels: light samples; x: point lights", title_fontsize=7)
fig.suptitle("Soft shadows: accuracy against speed (reference: 4,096 light × 8×8 pixel samples)", fontsize=11)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=90)
