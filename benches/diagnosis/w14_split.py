#!/usr/bin/env python3
"""ABBA's time below 70 mg/dL split by the patients it comes from (issue 26
item 2, the paper's W14 safety mark of 0.3 %).

For each scenario and evaluation week, over the patients every one of abba,
standard and r2r has in the week: ABBA's mean time below 70 mg/dL and
standard therapy's, then how much of ABBA's mean comes from the patients
whom standard therapy itself leaves at least THRESHOLD % below 70 in that
week (hypoglycaemic on the settings the trial starts from), and how much
from the rest.

Usage: python3 benches/diagnosis/w14_split.py REPORT_DIR [THRESHOLD=4]
"""
import collections
import csv
import sys

threshold = float(sys.argv[2]) if len(sys.argv) > 2 else 4.0
by = collections.defaultdict(dict)
for r in csv.DictReader(open(sys.argv[1] + "/patients.csv")):
    by[(r["scenario"], r["week"], r["patient"])][r["advisor"]] = r


def below(arm_row):
    return float(arm_row["below_70"])


scenarios = sorted({s for s, _, _ in by})
for sc in scenarios:
    for wk in ("W13", "W14"):
        rows = [
            v
            for (s, w, _), v in by.items()
            if s == sc and w == wk and all(a in v for a in ("abba", "standard", "r2r"))
        ]
        n = len(rows)
        if n == 0:
            continue
        abba = sum(below(v["abba"]) for v in rows) / n
        std = sum(below(v["standard"]) for v in rows) / n
        low = [v for v in rows if below(v["standard"]) >= threshold]
        from_low = sum(below(v["abba"]) for v in low) / n
        their_std = sum(below(v["standard"]) for v in low) / n
        print(
            f"{sc} {wk} n={n}: ABBA <70 {abba:.2f} %, standard {std:.2f} | "
            f"{len(low)} patients >= {threshold:g} % on standard: {from_low:.2f} "
            f"(standard {their_std:.2f}); the other {n - len(low)}: {abba - from_low:.2f}"
        )
