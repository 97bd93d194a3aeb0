#!/usr/bin/env python3
"""LBGI and HBGI by two-hour bin of the day, per arm, from a trial's
minute traces (`abba trial --trace NAMES --out DIR`; issue 26 item 2: at
which hours does ABBA's hyperglycaemia exceed run-to-run's?).

Plasma glucose every 5 minutes of days FIRST..LAST (W13 = 84..90 by
default) of every traced patient of SCENARIO; Kovatchev's risk function.
Each bin's figure is the bin's contribution scaled to a whole-day index
(the twelve bins average to the day's LBGI / HBGI).

Usage: python3 benches/diagnosis/risk_by_hour.py TRACE_DIR [SCENARIO=S1] [FIRST=84] [LAST=90]
"""
import collections
import csv
import glob
import math
import sys

trace_dir = sys.argv[1]
scenario = sys.argv[2] if len(sys.argv) > 2 else "S1"
first = int(sys.argv[3]) if len(sys.argv) > 3 else 84
last = int(sys.argv[4]) if len(sys.argv) > 4 else 90


def risk(g):
    f = 1.509 * (math.log(g) ** 1.084 - 5.381)
    r = 10 * f * f
    return (r, 0.0) if f < 0 else (0.0, r)


for arm in ("abba", "r2r", "standard"):
    lbgi, hbgi, n = collections.Counter(), collections.Counter(), 0
    files = sorted(glob.glob(f"{trace_dir}/*-{scenario}-{arm}.csv"))
    for path in files:
        for r in csv.DictReader(open(path)):
            day, minute = int(r["day"]), int(r["minute"])
            if not first <= day <= last or minute % 5:
                continue
            lo, hi = risk(max(float(r["plasma_mg_dl"]), 1.0))
            b = (minute % 1440) // 120
            lbgi[b] += lo
            hbgi[b] += hi
            n += 1
    if n == 0:
        continue
    per_bin = n / 12
    print(f"{arm} ({len(files)} patients): LBGI {sum(lbgi.values()) / n:.2f}, HBGI {sum(hbgi.values()) / n:.2f}")
    print("  HBGI by 2 h from 00:00:", " ".join(f"{hbgi[b] / per_bin:.2f}" for b in range(12)))
    print("  LBGI by 2 h from 00:00:", " ".join(f"{lbgi[b] / per_bin:.2f}" for b in range(12)))
