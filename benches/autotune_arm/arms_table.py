#!/usr/bin/env python3
"""The arms of an `abba trial` report side by side, W13 and W14, as the
Markdown rows BENCHMARKS.md quotes: TIR, time below 70 mg/dL and LBGI + HBGI
(means over the patients every arm has in that week, as table1.md's arms
table), runs stopped, and the autotune arm's final settings against the
start (median ratio). Usage: arms_table.py REPORT_DIR"""
import csv
import statistics
import sys
from collections import defaultdict

ARMS = ["abba", "standard", "r2r", "autotune"]


def main(folder):
    rows = list(csv.DictReader(open(f"{folder}/patients.csv")))
    by = defaultdict(dict)
    stopped = defaultdict(set)
    final = defaultdict(list)
    for r in rows:
        by[(r["scenario"], r["week"], r["advisor"])][r["patient"]] = r
        if r["stopped_day"]:
            stopped[(r["scenario"], r["advisor"])].add(r["patient"])
        if r["advisor"] == "autotune" and r["week"] == "W1":
            final[r["scenario"]].append(
                (
                    float(r["final_basal_u_per_h"]) / float(r["start_basal_u_per_h"]),
                    float(r["final_carb_ratio_breakfast_g_per_u"])
                    / float(r["start_carb_ratio_g_per_u"]),
                )
            )
    arms = [a for a in ARMS if any(k[2] == a for k in by)]
    scenarios = sorted({k[0] for k in by})
    head = "| scenario | week | n | " + " | ".join(
        f"{a} TIR | {a} <70 | {a} L+H" for a in arms
    )
    print(head + " |")
    print("|---|---|---:|" + "---:|" * (3 * len(arms)))
    for s in scenarios:
        for w in ["W13", "W14"]:
            common = set.intersection(*(set(by[(s, w, a)]) for a in arms))
            cells = []
            for a in arms:
                ps = [by[(s, w, a)][p] for p in sorted(common)]
                m = lambda f: statistics.mean(f(p) for p in ps)
                cells += [
                    f"{m(lambda p: float(p['tir_70_180'])):.1f}",
                    f"{m(lambda p: float(p['below_70'])):.2f}",
                    f"{m(lambda p: float(p['lbgi']) + float(p['hbgi'])):.2f}",
                ]
            print(f"| {s} | {w} | {len(common)} | " + " | ".join(cells) + " |")
    print()
    print(
        "stopped runs: "
        + "; ".join(
            f"{s} " + ", ".join(f"{a} {len(stopped[(s, a)])}" for a in arms)
            for s in scenarios
        )
    )
    for s in scenarios:
        if final[s]:
            b = statistics.median(x[0] for x in final[s])
            c = statistics.median(x[1] for x in final[s])
            print(f"{s} autotune final/start median: basal {b:.3f}, breakfast carb ratio {c:.3f}")


if __name__ == "__main__":
    main(sys.argv[1])
