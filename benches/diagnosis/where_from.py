#!/usr/bin/env python3
"""Where ABBA's remaining hypoglycaemia and its W13 hyperglycaemia come
from, per patient, from a trial report's patients.csv (issue 26 item 2).

For S1, S2 and S4 at W13 and W14, over the patients every one of abba,
standard and r2r has in the week: ABBA's mean time below 70 mg/dL, how many
patients have any, the share of the five worst, in how many patients ABBA
has more time below 70 than standard therapy, the five worst with their
final basal and dinner carb ratio relative to the start; in how many
patients run-to-run's LBGI + HBGI is lower, and the arms' mean HBGI. Then
each arm's final settings relative to the start (median [Q1, Q3]).

Usage: python3 benches/diagnosis/where_from.py REPORT_DIR
"""
import collections
import csv
import statistics
import sys

rows = list(csv.DictReader(open(sys.argv[1] + "/patients.csv")))
by = collections.defaultdict(dict)
for r in rows:
    by[(r["scenario"], r["advisor"], r["week"])][r["patient"]] = r


def f(r, k):
    return float(r[k])


for sc in ("S1", "S2", "S4"):
    for w in ("W13", "W14"):
        a, s, r2 = (by[(sc, arm, w)] for arm in ("abba", "standard", "r2r"))
        pts = [p for p in a if p in s and p in r2]
        if not pts:
            continue  # a scenario the trial did not run
        low = sorted(((f(a[p], "below_70"), p) for p in pts), reverse=True)
        total = sum(x for x, _ in low)
        worse = sum(1 for p in pts if f(a[p], "below_70") > f(s[p], "below_70"))
        lh = lambda d, p: f(d[p], "lbgi") + f(d[p], "hbgi")
        r2r_lower = sum(1 for p in pts if lh(r2, p) < lh(a, p))
        hb = lambda d: statistics.mean(f(d[p], "hbgi") for p in pts)
        print(f"{sc} {w} n={len(pts)}: <70 {total / len(pts):.2f} %, "
              f"{sum(1 for x, _ in low if x > 0)} patients with any, five worst "
              f"{sum(x for x, _ in low[:5]) / total:.0%}; ABBA above standard in {worse}; "
              f"r2r L+H lower in {r2r_lower}; HBGI ABBA {hb(a):.2f}, r2r {hb(r2):.2f}")
        for x, p in low[:5]:
            start = f(a[p], "start_basal_u_per_h")
            print(f"   {p}: {x:.1f} % (standard {f(s[p], 'below_70'):.1f}), basal "
                  f"x{f(a[p], 'final_basal_u_per_h') / start:.2f}, dinner CR "
                  f"x{f(a[p], 'final_carb_ratio_dinner_g_per_u') / f(a[p], 'start_carb_ratio_g_per_u'):.2f}")
first = [r for r in rows if r["week"] == "W1"]
for sc in ("S1", "S2"):
    for arm in ("abba", "r2r"):
        rs = [r for r in first if r["scenario"] == sc and r["advisor"] == arm]
        if len(rs) < 2:
            continue
        def q(v):
            qs = statistics.quantiles(v, n=4)
            return f"{statistics.median(v):.2f} [{qs[0]:.2f}, {qs[2]:.2f}]"
        basal = [f(r, "final_basal_u_per_h") / f(r, "start_basal_u_per_h") for r in rs]
        crs = {m: [f(r, f"final_carb_ratio_{m}_g_per_u") / f(r, "start_carb_ratio_g_per_u")
                   for r in rs] for m in ("breakfast", "lunch", "dinner")}
        print(f"{sc} {arm}: basal {q(basal)}; " + "; ".join(f"{m} CR {q(v)}" for m, v in crs.items()))
