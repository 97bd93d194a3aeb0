#!/usr/bin/env python3
"""Does ABBA's learning count where a fixed rule must fall behind?

S6 is S1 with insulin sensitivity drifting +-30 % over six weeks. For each
held-out cohort (cohort seed = trial seed, never used to choose a default)
this runs `abba trial --patients N --scenarios S1,S6 --arms abba,standard`
twice: with the learning actor (`abba.actor.natural_beta` = 0.05, the
calibrated value) and with it frozen (0, the default since issue 26; the
only change), then prints ABBA's W13 and
W14 LBGI + HBGI, TIR and time below 70 mg/dL for both, and the difference.

Usage: python3 benches/s6_learning/run.py ABBA_BINARY OUT_DIR [N] [SEEDS...]
(default N = 50, seeds 202 303 404).
"""
import json
import subprocess
import sys
from pathlib import Path

abba, out = sys.argv[1], Path(sys.argv[2])
n = sys.argv[3] if len(sys.argv) > 3 else "50"
seeds = sys.argv[4:] or ["202", "303", "404"]
out.mkdir(parents=True, exist_ok=True)
cfg = json.loads(subprocess.run([abba, "trial", "--print-config"], check=True,
                                capture_output=True, text=True).stdout)
learning, frozen = out / "learning.json", out / "frozen.json"
cfg["abba"]["actor"]["natural_beta"] = 0.05
learning.write_text(json.dumps(cfg, indent=1))
cfg["abba"]["actor"]["natural_beta"] = 0.0
frozen.write_text(json.dumps(cfg, indent=1))
print("cohort | scenario | week | L+H learning / frozen (diff) | TIR | <70 | standard L+H")
for seed in seeds:
    runs = {}
    for name, extra in (("learning", ["--config", str(learning)]),
                        ("frozen", ["--config", str(frozen)])):
        d = out / f"{name}-{seed}"
        subprocess.run([abba, "trial", "--quiet", *extra, "--patients", n,
                        "--scenarios", "S1,S6", "--arms", "abba,standard",
                        "--cohort-seed", seed, "--seed", seed, "--out", str(d)],
                       check=True, capture_output=True)
        runs[name] = json.loads((d / "summary.json").read_text())["arms"]
    for sc in ("S1", "S6"):
        for w in ("W13", "W14"):
            def get(name, arm="abba"):
                m = runs[name][f"{sc}/{arm}"]["weeks"][w]
                return (m["lbgi"]["mean"] + m["hbgi"]["mean"],
                        m["tir_70_180"]["mean"], m["below_70"]["mean"])
            a, b, s = get("learning"), get("frozen"), get("learning", "standard")
            print(f"{seed} | {sc} | {w} | {a[0]:.3f} / {b[0]:.3f} ({a[0] - b[0]:+.3f}) | "
                  f"{a[1]:.2f} / {b[1]:.2f} | {a[2]:.2f} / {b[2]:.2f} | {s[0]:.3f}")
