"""Adaptive against uniform light sampling at equal error, from docs/area_lights.csv.

The error is light_rms_levels: against the same pixel samples with the reference's light
samples, so that only the light sampling's noise and bias count. For each scene, pixel samples
and uniform light-sample count from 16 on: uniform's error and time, and the time adaptive
sampling needs for the same error (log-log interpolation between its renders at 4, 16, 64, …
light samples, 4 being uniform's render; '>' where its renders do not reach it).
Prints a Markdown table. Usage: python3 scripts/area_light_equal_error.py docs/area_lights.csv
"""
import csv
import math
import sys

rows = list(csv.DictReader(open(sys.argv[1])))


def time_at(curve, level):
    """The time at which a curve of (ms, error) points, by growing samples, first has `level`."""
    for (t0, e0), (t1, e1) in zip(curve, curve[1:]):
        if e1 <= level < e0:
            f = (math.log(e0) - math.log(level)) / (math.log(e0) - math.log(e1))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    if curve and curve[0][1] <= level:
        return curve[0][0]  # already at the first render: at most its time
    return None


print("| scene | pixel samples | uniform light samples | error (levels) | uniform ms | adaptive ms at that error | uniform / adaptive |")
print("|---|---|---|---|---|---|---|")
for scene in ("note", "knot"):
    for pixel in (1, 2, 4):
        mine = [r for r in rows if r["scene"] == scene and int(r["pixel_samples"]) == pixel]

        def curve(method):
            pts = [r for r in mine if int(r["light_samples"]) >= 4 and
                   (r["method"] == method or (r["method"] == "uniform" and int(r["light_samples"]) < 8))]
            pts.sort(key=lambda r: int(r["light_samples"]))
            return [(float(r["ms"]), max(float(r["light_rms_levels"]), 1e-6)) for r in pts]

        adaptive = curve("adaptive")
        for u in sorted((r for r in mine if r["method"] == "uniform" and int(r["light_samples"]) >= 16),
                        key=lambda r: int(r["light_samples"])):
            level, ms = float(u["light_rms_levels"]), float(u["ms"])
            t = time_at(adaptive, level)
            if t is None:
                print(f"| {scene} | {pixel}×{pixel} | {u['light_samples']} | {level:.2f} | {ms:.1f} | > {adaptive[-1][0]:.1f} | < {ms / adaptive[-1][0]:.2f} |")
            else:
                print(f"| {scene} | {pixel}×{pixel} | {u['light_samples']} | {level:.2f} | {ms:.1f} | {t:.1f} | {ms / t:.2f} |")
