#!/usr/bin/env python3
"""Per-round speed ratios from `cargo xtask eval` results.json files (docs/results/2026-12-02-isa-matched).

Usage: ratios.py RUN.json [RUN.json ...]

For every run, scene and ray kind: each pair (sahara layout and tree, other engine) traced in
the same interleaved rounds gives one ratio per round, other engine's seconds / sahara's
seconds (> 1: sahara is faster); printed as the median with min-max over rounds, next to both
engines' median Mrays/s. Pairs: sahara's wide layout (bvh8, or bvh4 when bvh8 was not traced)
with the sweep tree against Embree, tinybvh and obvhs, and with the SBVH tree against Embree and
tinybvh-hq.
"""
import json
import statistics
import sys

PAIRS = [
    ("sweep", "embree"),
    ("sbvh", "embree"),
    ("sweep", "tinybvh"),
    ("sbvh", "tinybvh-hq"),
    ("sweep", "tinybvh-hq"),
    ("sweep", "obvhs"),
    ("sbvh", "obvhs"),
]


def rows(results):
    out = {}
    for t in results["traces"]:
        out.setdefault((t["scene"], t["ray_kind"], t["layout"], t["builder"]), t)
        # Foreign engines: every builder's row holds the same figures; keep the first.
        out.setdefault((t["scene"], t["ray_kind"], t["layout"], "*"), t)
    return out


def main(paths):
    print("| run | scene | rays | sahara | tree | other | backend(s) | sahara Mrays/s | other Mrays/s | other time / sahara time: median (min–max), rounds |")
    print("|---|---|---|---|---|---|---|---:|---:|---|")
    for path in paths:
        r = json.load(open(path))
        s = r["meta"]["settings"]
        layouts = s["layouts"]
        wide = "bvh8" if "bvh8" in layouts else ("bvh4" if "bvh4" in layouts else layouts[0])
        idx = rows(r)
        scenes = [sc["name"] for sc in r["scenes"]]
        kinds = s["rays"]
        for sc in scenes:
            for k in kinds:
                for tree, other in PAIRS:
                    if other not in layouts:
                        continue
                    a = idx.get((sc, k, wide, tree))
                    b = idx.get((sc, k, other, "*"))
                    if not a or not b:
                        continue
                    ra, rb = a["round_seconds"], b["round_seconds"]
                    q = [y / x for x, y in zip(ra, rb) if x > 0]
                    if not q:
                        continue
                    print(
                        f"| {path.split('/')[-1]} | {sc} | {k} | {wide} | {tree} | {other} | "
                        f"{a['backend']} / {b['backend']} | {a['mrays_s']['median']:.2f} | "
                        f"{b['mrays_s']['median']:.2f} | **{statistics.median(q):.2f}** "
                        f"({min(q):.2f}–{max(q):.2f}), {len(q)} |"
                    )


if __name__ == "__main__":
    main(sys.argv[1:])
