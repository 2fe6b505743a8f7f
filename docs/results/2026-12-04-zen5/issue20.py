#!/usr/bin/env python3
"""The issue-20 table from `xtask build-bench` output (README.md of this folder):
`issue20.py build-bench-after.txt`. Ratios are build-bench's own: the median over rounds of
(sahara build + collapse to bvh8) / (Embree rtcCommitScene) of the same round."""
import re
import sys

rows = {}
order = []
for line in open(sys.argv[1]):
    f = line.split()
    if len(f) < 3 or f[1] not in ("binned", "sweep", "sbvh", "tsah-topk", "hybrid",
                                  "embree-medium", "embree-high"):
        continue
    scene, engine = f[0], f[1]
    if scene not in rows:
        rows[scene] = {}
        order.append(scene)
    med = lambda name: re.search(name + r" ([0-9.]+)x", line)
    times = re.findall(r"([0-9.]+) \([0-9.]+-[0-9.]+\)", line)
    rows[scene][engine] = {"total": float(times[-1]) if engine[:6] != "embree" else float(times[0]),
                           "medium": med("embree-medium"), "high": med("embree-high")}

def ratio(r, engine, q):
    m = r[engine][q]
    return m.group(1) if m else "n/a"

print("| scene | binned ÷ MEDIUM | sweep ÷ MEDIUM | sbvh ÷ HIGH | tsah-topk | hybrid | Embree MEDIUM / HIGH (ms) |")
print("|---|---:|---:|---:|---:|---:|---:|")
for s in order:
    r = rows[s]
    ms = lambda e: r[e]["total"]
    fmt = lambda t: f"{t / 1000:.2f} s" if t >= 1000 else f"{t:.0f} ms"
    print(f"| {s} | {ratio(r, 'binned', 'medium')} | {ratio(r, 'sweep', 'medium')} | "
          f"{ratio(r, 'sbvh', 'high')} | {fmt(ms('tsah-topk'))} | {fmt(ms('hybrid'))} | "
          f"{ms('embree-medium'):.1f} / {ms('embree-high'):.1f} |")
