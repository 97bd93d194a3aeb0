"""Tunes the run-to-run baseline's gains once, on held-out patients, as
abba-algorithm.md §10.2 asks ("tune K_B and K_C once on a held-out subset,
grid {0.1, 0.2, 0.3, 0.5}, and freeze them").

Held out: the first 20 adults of cohort seed 2 (the trial uses seed 1).
Scenarios S1 (CGM mode) and S2 (SMBG mode), 98 days. Criterion, per gain
pair: runs stopped below the failure threshold first (fewer is better), then
the mean Kovatchev risk index LBGI + HBGI over W13 and W14 (lower is better).

    cargo build --release -p abba
    python3 benches/r2r_gains.py
"""
import itertools
import json
import subprocess
import tempfile

ABBA = "target/release/abba"
GRID = [0.1, 0.2, 0.3, 0.5]


def evaluate(kb, kc, base):
    config = json.loads(json.dumps(base))
    config["r2r"]["basal_gain"] = kb
    config["r2r"]["cir_gain"] = kc
    config["cohort_seed"] = 2
    with tempfile.TemporaryDirectory() as tmp:
        path = f"{tmp}/config.json"
        with open(path, "w") as f:
            json.dump(config, f)
        subprocess.run([ABBA, "trial", "--config", path, "--patients", "20", "--scenarios",
                        "S1,S2", "--arms", "r2r", "--out", tmp, "--quiet"], check=True)
        with open(f"{tmp}/summary.json") as f:
            summary = json.load(f)
        with open(f"{tmp}/summary_notes.json") as f:
            notes = json.load(f)
    stops, risk, tir, below = 0, [], [], []
    for key, arm in summary["arms"].items():
        stops += len(notes["arms"][key]["stopped_runs"])
        for week in ("W13", "W14"):
            m = arm["weeks"][week]
            risk.append(m["lbgi"]["mean"] + m["hbgi"]["mean"])
            tir.append(m["tir_70_180"]["mean"])
            below.append(m["below_70"]["mean"])
    mean = lambda xs: sum(xs) / len(xs)
    return stops, mean(risk), mean(tir), mean(below)


def main():
    base = json.loads(subprocess.run([ABBA, "trial", "--print-config"], check=True,
                                     capture_output=True, text=True).stdout)
    print("| K_B | K_C | stopped runs | LBGI+HBGI (W13, W14) | TIR | % < 70 |")
    print("|---:|---:|---:|---:|---:|---:|")
    results = []
    for kb, kc in itertools.product(GRID, GRID):
        stops, risk, tir, below = evaluate(kb, kc, base)
        results.append(((stops, risk), kb, kc))
        print(f"| {kb} | {kc} | {stops} | {risk:.2f} | {tir:.1f} | {below:.2f} |", flush=True)
    best = min(results)
    print(f"\nchosen: K_B = {best[1]}, K_C = {best[2]} (stopped {best[0][0]}, risk {best[0][1]:.2f})")


if __name__ == "__main__":
    main()
