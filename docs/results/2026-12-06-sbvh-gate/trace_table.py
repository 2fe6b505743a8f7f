#!/usr/bin/env python3
"""Trace speed of the bvh8 kernel over the `sbvh` and `sbvh-fast` trees against Embree's own
HIGH tree, from the eval results in this folder (README.md): `trace_table.py
avx2-high.results.json`. A ratio is the median over rounds of the per-round time ratio (the
engines alternate within each round); > 1 means the first named is faster."""
import json
import statistics
import sys

d = json.load(open(sys.argv[1]))
t = {(r["scene"], r["ray_kind"], r["builder"], r["layout"]): r for r in d["traces"]}
scenes = []
for k in t:
    if k[0] not in scenes:
        scenes.append(k[0])


def speed(x, y):
    """Speed of x over y: median of y's time / x's time over rounds."""
    return statistics.median(ty / tx for tx, ty in zip(x["round_seconds"], y["round_seconds"]))


print("| scene | rays | sbvh ÷ Embree HIGH | sbvh-fast ÷ Embree HIGH | sbvh-fast ÷ sbvh | "
      "inner nodes per ray sbvh / sbvh-fast |")
print("|---|---|---:|---:|---:|---:|")
all_ratios = []
for s in scenes:
    for k in ["primary", "diffuse", "ao"]:
        a = t[(s, k, "sbvh", "bvh8")]
        b = t[(s, k, "sbvh-fast", "bvh8")]
        e = t[(s, k, "sbvh", "embree")]
        all_ratios.append(speed(b, a))
        print(f"| {s} | {k} | {speed(a, e):.3f} | {speed(b, e):.3f} | {speed(b, a):.3f} | "
              f"{a['inner_per_ray']:.2f} / {b['inner_per_ray']:.2f} |")
print(f"\nsbvh-fast ÷ sbvh over all cells: median {statistics.median(all_ratios):.3f}, "
      f"range {min(all_ratios):.3f}-{max(all_ratios):.3f}")
