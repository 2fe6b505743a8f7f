#!/usr/bin/env python3
"""ISA-matched speed ratios from `cargo xtask eval` results.json files (docs/results/2026-12-02-isa-xeon).

Usage: ratios.py RUN.results.json|RUN_DIR/results.json [...]

For every run, scene and ray kind, each pair (sahara's wide layout with a tree, another
engine) traced in the same interleaved rounds gives one ratio per round: the other engine's
seconds / sahara's seconds (> 1: sahara faster). A cell is the median of those ratios with a
95% percentile-bootstrap interval (2000 resamples of the rounds, fixed seed), the same protocol
as the eval's own intervals (xtask/src/eval/interval.rs). Verdict: "win" when the interval
lies above 1, "loss" below 1, "tie" when it contains 1. Prints one markdown row per cell and
a count of verdicts per run.
"""
import json
import random
import statistics
import sys

PAIRS = [("sweep", "embree"), ("sbvh", "embree"), ("sweep", "tinybvh"),
         ("sbvh", "tinybvh-hq"), ("sweep", "obvhs"), ("sbvh", "obvhs")]


def interval(q, resamples=2000, seed=0x5A4A7A15):
    rng = random.Random(seed)
    meds = sorted(statistics.median(rng.choices(q, k=len(q))) for _ in range(resamples))
    return meds[int(0.025 * resamples)], meds[int(0.975 * resamples) - 1]


def main(paths):
    print("| run | scene | rays | tree | other | sahara Mrays/s | other Mrays/s | ratio (95% interval), rounds | verdict |")
    print("|---|---|---|---|---|---:|---:|---|---|")
    tallies = {}
    for path in paths:
        r = json.load(open(path))
        # The run's name: the file's name before ".results.json", else its folder's name.
        name = path.rstrip("/").split("/")
        run = name[-1].removesuffix(".results.json") if name[-1] != "results.json" else name[-2]
        layouts = r["meta"]["settings"]["layouts"]
        wide = "bvh8" if "bvh8" in layouts else "bvh4"
        idx = {}
        for t in r["traces"]:
            idx.setdefault((t["scene"], t["ray_kind"], t["layout"], t["builder"]), t)
            idx.setdefault((t["scene"], t["ray_kind"], t["layout"], "*"), t)
        for sc in [s["name"] for s in r["scenes"]]:
            for k in r["meta"]["settings"]["rays"]:
                for tree, other in PAIRS:
                    a, b = idx.get((sc, k, wide, tree)), idx.get((sc, k, other, "*"))
                    if other not in layouts or not a or not b:
                        continue
                    q = [y / x for x, y in zip(a["round_seconds"], b["round_seconds"]) if x > 0 and y > 0]
                    if not q:
                        continue
                    lo, hi = interval(q)
                    verdict = "win" if lo > 1 else ("loss" if hi < 1 else "tie")
                    key = (run, other, tree)
                    tallies.setdefault(key, {"win": 0, "tie": 0, "loss": 0})[verdict] += 1
                    print(f"| {run} | {sc} | {k} | {wide} {a['backend']} {tree} | {other} {b['backend']} | "
                          f"{a['mrays_s']['median']:.2f} | {b['mrays_s']['median']:.2f} | "
                          f"**{statistics.median(q):.3f}** ({lo:.3f}–{hi:.3f}), {len(q)} | {verdict} |")
    print()
    print("| run | other | tree | wins | ties | losses |")
    print("|---|---|---|---:|---:|---:|")
    for (run, other, tree), t in sorted(tallies.items()):
        print(f"| {run} | {other} | {tree} | {t['win']} | {t['tie']} | {t['loss']} |")


if __name__ == "__main__":
    main(sys.argv[1:])
