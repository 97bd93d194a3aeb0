"""Compares abba's patient model with simglucose's on every public patient
and every built-in hard day: the largest |G_abba - G_simglucose| (plasma
glucose, mg/dL) over all minutes.

    cargo build --release -p abba
    python3 -m venv /tmp/sg && /tmp/sg/bin/pip install simglucose==0.2.11
    /tmp/sg/bin/python benches/simglucose_compare.py
"""
import csv
import os
import subprocess
import tempfile

from simglucose.patient.t1dpatient import Action, T1DPatient

ABBA = "target/release/abba"
DAYS = ["standard", "overlapping-meals", "missed-boluses", "insulin-suspension", "long-fast"]


def names():
    with open("data/uva-padova/vpatient_params.csv") as f:
        return [row["Name"] for row in csv.DictReader(f)]


def main():
    worst_all = (0.0, "", "")
    print("| day | largest max |G_abba - G_simglucose| (mg/dL) | patient |")
    print("|---|---:|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for day in DAYS:
            worst = (0.0, "")
            for name in names():
                out, inputs = os.path.join(tmp, "bg.csv"), os.path.join(tmp, "in.csv")
                subprocess.run([ABBA, "simulate", "--patient", name, "--day", day, "--out", out,
                                "--inputs-out", inputs], check=True)
                with open(out) as f:
                    ours = [float(r["bg_mg_dl"]) for r in csv.DictReader(f)]
                with open(inputs) as f:
                    rows = list(csv.DictReader(f))
                patient = T1DPatient.withName(name)
                vg = patient._params.Vg
                theirs = [patient.state[3] / vg]
                for r in rows:
                    # Each minute's eaten grams (at most 5) announced that
                    # minute is eaten that minute by simglucose's queue.
                    patient.step(Action(CHO=float(r["cho_g_per_min"]),
                                        insulin=float(r["insulin_u_per_min"])))
                    theirs.append(patient.state[3] / vg)
                err = max(abs(a - b) for a, b in zip(ours, theirs))
                if err > worst[0]:
                    worst = (err, name)
                if err > worst_all[0]:
                    worst_all = (err, name, day)
            print(f"| {day} | {worst[0]:.2e} | {worst[1]} |", flush=True)
    print(f"\nlargest overall: {worst_all[0]:.2e} mg/dL ({worst_all[1]}, {worst_all[2]})")


if __name__ == "__main__":
    main()
