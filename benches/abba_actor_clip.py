"""Sweeps ABBA's actor-step clip (`abba.actor.theta_step_clip`) and prints,
per scenario, the runs stopped below the failure threshold and the mean
W1/W13/W14 time in range, below 70 and above 180 mg/dL.

    cargo build --release -p abba
    python3 benches/abba_actor_clip.py [patients] [cohort_seed] [clip ...]
"""
import json
import subprocess
import sys
import tempfile

ABBA = "target/release/abba"


def run(clip, patients, cohort_seed, scenarios="S1,S2,S4"):
    config = json.loads(subprocess.run([ABBA, "trial", "--print-config"], check=True,
                                       capture_output=True, text=True).stdout)
    config["abba"]["actor"]["theta_step_clip"] = clip
    config["cohort_seed"] = cohort_seed
    with tempfile.TemporaryDirectory() as tmp:
        path = f"{tmp}/config.json"
        with open(path, "w") as f:
            json.dump(config, f)
        subprocess.run([ABBA, "trial", "--config", path, "--patients", str(patients),
                        "--scenarios", scenarios, "--arms", "abba", "--out", tmp, "--quiet"],
                       check=True)
        with open(f"{tmp}/summary.json") as f:
            summary = json.load(f)
        with open(f"{tmp}/summary_notes.json") as f:
            notes = json.load(f)
    for key, arm in summary["arms"].items():
        def mean(week, metric):
            w = arm["weeks"].get(week)
            return w[metric]["mean"] if w and w.get(metric) else float("nan")
        stops = len(notes["arms"][key]["stopped_runs"])
        print(f"| {clip} | {key} | {stops} | "
              + " | ".join(f"{mean(w, m):.1f}" for m in ("tir_70_180", "below_70", "above_180")
                           for w in ("W1", "W13", "W14"))
              + f" | {mean('W13', 'lbgi'):.2f} | {mean('W13', 'hbgi'):.2f} |")


def main():
    patients = int(sys.argv[1]) if len(sys.argv) > 1 else 30
    cohort_seed = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    clips = [float(c) for c in sys.argv[3:]] or [0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5]
    print("| clip | arm | stopped | TIR W1 | TIR W13 | TIR W14 | <70 W1 | <70 W13 | <70 W14 "
          "| >180 W1 | >180 W13 | >180 W14 | LBGI W13 | HBGI W13 |")
    print("|" + "---|" * 14)
    for clip in clips:
        run(clip, patients, cohort_seed)


if __name__ == "__main__":
    main()
