"""abba's twin against ReplayBG (py-replay-bg) on the same windows of real
open-loop pump exports: HUPA-UCM's raw Medtronic CareLink and FreeStyle
Libre files (README.md says where they come from and their licence).

For each person, the window is the last FIT + HELD local days with a full
Libre record inside the pump export. Both tools get the same per-minute
inputs (hupa.py): the delivered basal and boluses, and the bolus wizard's
carbohydrate; both are fitted on the FIT days and predict the HELD days
from their recorded inputs, and both are scored on the same Libre
readings of the held-out days:

- ReplayBG: multi-meal blueprint, MAP (its default 128 Powell starts),
  one day at a time, each day starting from the end state of the day
  before (its documented "intervals" procedure); the held-out days are
  replayed with the twin of the last fitted day.
- abba: the data written as Nightscout entries / treatments / profile,
  imported into a throwaway store through `abba import`, then
  `abba twin fit --days FIT+HELD --held-out HELD --json`.
- the constant predictor: every held-out reading predicted by the held-out
  days' own mean glucose (the bar a twin must clear to say anything).

    python3 -m venv target/replaybg-venv
    target/replaybg-venv/bin/pip install py-replay-bg==1.4.0
    target/replaybg-venv/bin/python benches/replaybg/run.py \\
        --pump pump_all.csv --libre libre_all.csv --abba target/release/abba

ReplayBG is a benchmark dependency only (GPL-3.0): nothing in abba's build,
tests or runtime imports it.
"""

import argparse
import contextlib
import datetime as dt
import hashlib
import io
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import zoneinfo

import hupa

TZ = "Europe/Madrid"
MEAL_WINDOWS = [(5 * 60, 10 * 60 + 30, "B"), (10 * 60 + 30, 15 * 60 + 30, "L"), (15 * 60 + 30, 22 * 60, "D")]
MEAL_BOLUS_WINDOW_MIN = 20


def slot(minute_of_day):
    for lo, hi, label in MEAL_WINDOWS:
        if lo <= minute_of_day < hi:
            return label
    return "S"


# ---------------------------------------------------------------- ReplayBG


def replaybg_frame(rec, day, yts=5):
    """One local day of `rec` as ReplayBG's data frame: a 5-min grid, cho
    and insulin as per-minute rates over each step, glucose at the Libre's
    readings (NaN between them)."""
    import numpy as np
    import pandas as pd

    t0 = dt.datetime.combine(rec.day0 + dt.timedelta(days=day), dt.time())
    base = day * 1440
    glucose = {m - base: g for m, g in rec.glucose if base <= m < base + 1440}
    rows = []
    for k in range(0, 1440, yts):
        span = range(base + k, base + k + yts)
        cho = sum(rec.carbs_g[m] for m in span)
        bolus = sum(rec.bolus_u[m] for m in span)
        basal = sum(rec.basal_u_per_h[m] for m in span) / 60.0
        g = [glucose[m] for m in range(k, k + yts) if m in glucose]
        rows.append({
            "t": t0 + dt.timedelta(minutes=k),
            "glucose": g[0] if g else np.nan,
            "cho": cho / yts,
            "bolus": bolus / yts,
            "basal": basal / yts,
            "cho_label": slot(k) if cho > 0 else "",
            "bolus_label": "",
        })
    df = pd.DataFrame(rows)
    # A bolus within 20 min of a meal is that meal's; others corrections.
    meals = [i for i, r in enumerate(rows) if r["cho"] > 0]
    for i, r in enumerate(rows):
        if r["bolus"] > 0:
            near = [j for j in meals if abs(j - i) * yts <= MEAL_BOLUS_WINDOW_MIN]
            df.loc[i, "bolus_label"] = rows[near[0]]["cho_label"] if near else "C"
    df["cho_label"] = df["cho_label"].astype(object)
    df["bolus_label"] = df["bolus_label"].astype(object)
    return df


def run_replaybg(rec, fit_days, held_days, bw, workdir, starts, quiet=True):
    """Fits ReplayBG on the first `fit_days` of `rec` and replays the
    following `held_days`: (predicted glucose per minute of the held-out
    days, fit seconds, replay seconds). `starts` replaces MAP's 128 Powell
    starts when given (for a quick look only: the table uses 128)."""
    from py_replay_bg.py_replay_bg import ReplayBG
    from py_replay_bg.twinning.map import MAP

    if starts and not getattr(MAP, "_starts_patched", False):
        init = MAP.__init__

        def patched(self, *a, **k):
            init(self, *a, **k)
            self.n_rerun = starts

        MAP.__init__ = patched
        MAP._starts_patched = True

    rbg = ReplayBG(blueprint="multi-meal", save_folder=workdir, yts=5, exercise=False, seed=1,
                   verbose=False, plot_mode=False)
    frames = [replaybg_frame(rec, d) for d in range(fit_days + held_days)]
    mean_basal_u_per_min = sum(rec.basal_u_per_h[: fit_days * 1440]) / 60.0 / (fit_days * 1440)
    u2ss = mean_basal_u_per_min * 1000.0 / bw  # mU/kg/min
    x0, prev = None, None
    fit_s = replay_s = 0.0
    sink = io.StringIO()
    for d in range(fit_days):
        name = f"fit_{d}"
        t = time.perf_counter()
        with contextlib.redirect_stdout(sink) if quiet else contextlib.nullcontext():
            rbg.twin(data=frames[d], bw=bw, save_name=name, twinning_method="map",
                     parallelize=False, x0=x0, u2ss=u2ss, previous_data_name=prev)
        fit_s += time.perf_counter() - t
        t = time.perf_counter()
        with contextlib.redirect_stdout(sink) if quiet else contextlib.nullcontext():
            res = rbg.replay(data=frames[d], bw=bw, save_name=name, twinning_method="map",
                             x0=x0, previous_data_name=prev)
        replay_s += time.perf_counter() - t
        x0 = res["x_end"]["realizations"][0].tolist()
        prev = name
    last = prev
    pred = []
    for d in range(fit_days, fit_days + held_days):
        t = time.perf_counter()
        with contextlib.redirect_stdout(sink) if quiet else contextlib.nullcontext():
            res = rbg.replay(data=frames[d], bw=bw, save_name=last, twinning_method="map",
                             x0=x0, previous_data_name=prev)
        replay_s += time.perf_counter() - t
        g = list(res["glucose"]["median"])
        if len(g) != 1440:
            raise RuntimeError(f"ReplayBG returned {len(g)} minutes for a day, expected 1440")
        pred.extend(g)
        x0 = res["x_end"]["realizations"][0].tolist()
        prev = last
    return pred, fit_s, replay_s


# -------------------------------------------------------------------- abba


def _iso(local, tz):
    return local.replace(tzinfo=tz).astimezone(dt.timezone.utc)


def _id(*parts):
    return hashlib.sha1("|".join(map(str, parts)).encode()).hexdigest()[:24]


def nightscout(rec, days, ratio_g_per_u):
    """`days` local days of `rec` as Nightscout entries, treatments and a
    profile: readings as sgv entries, carbohydrate as Carbs, boluses as
    Bolus (a square bolus as the 1-minute pieces it was delivered in), and
    the delivered basal as absolute Temp Basals over a flat profile at the
    median scheduled rate (so abba's tape sees exactly what ReplayBG sees)."""
    tz = zoneinfo.ZoneInfo(TZ)
    t0 = dt.datetime.combine(rec.day0, dt.time())
    n = days * 1440
    at = lambda m: _iso(t0 + dt.timedelta(minutes=m), tz)
    entries = [{
        "_id": _id("sgv", m, g), "type": "sgv", "sgv": g, "device": "FreeStyle Libre (HUPA-UCM)",
        "date": int(at(m).timestamp() * 1000), "dateString": at(m).isoformat().replace("+00:00", "Z"),
    } for m, g in rec.glucose if m < n]
    treatments = []
    for m in range(n):
        if rec.carbs_g[m] > 0:
            treatments.append({"_id": _id("carbs", m), "eventType": "Carbs", "carbs": rec.carbs_g[m],
                               "created_at": at(m).isoformat().replace("+00:00", "Z"), "enteredBy": "hupa.py"})
        if rec.bolus_u[m] > 0:
            treatments.append({"_id": _id("bolus", m), "eventType": "Bolus", "insulin": round(rec.bolus_u[m], 6),
                               "created_at": at(m).isoformat().replace("+00:00", "Z"), "enteredBy": "hupa.py"})
    m = 0
    while m < n:
        r = rec.basal_u_per_h[m]
        e = m
        while e < n and rec.basal_u_per_h[e] == r:
            e += 1
        treatments.append({"_id": _id("temp", m), "eventType": "Temp Basal", "absolute": r, "duration": e - m,
                           "created_at": at(m).isoformat().replace("+00:00", "Z"), "enteredBy": "hupa.py"})
        m = e
    sched = sorted(rec.scheduled_u_per_h[:n])[n // 2]
    start = at(0) - dt.timedelta(days=1)
    profile = [{
        "_id": _id("profile", rec.day0), "defaultProfile": "pump", "startDate": start.isoformat().replace("+00:00", "Z"),
        "mills": int(start.timestamp() * 1000), "units": "mg/dl",
        "store": {"pump": {
            "timezone": TZ, "units": "mg/dl", "dia": 5,
            "basal": [{"time": "00:00", "timeAsSeconds": 0, "value": sched}],
            "carbratio": [{"time": "00:00", "timeAsSeconds": 0, "value": round(ratio_g_per_u, 2)}],
        }},
    }]
    newest_first = lambda v: sorted(v, key=lambda x: x.get("date") or x.get("created_at"), reverse=True)
    return newest_first(entries), newest_first(treatments), profile


def run_abba(abba, rec, fit_days, held_days, workdir, name):
    days = fit_days + held_days
    ratio = rec.carb_ratio_g_per_u or 10.0
    entries, treatments, profile = nightscout(rec, days, ratio)
    d = os.path.join(workdir, "ns")
    os.makedirs(d, exist_ok=True)
    files = []
    for fname, doc in [("entries.json", entries), ("treatments.json", treatments), ("profile.json", profile)]:
        path = os.path.join(d, fname)
        with open(path, "w") as f:
            json.dump(doc, f)
        files.append(path)
    db = os.path.join(workdir, "store.sqlite")
    run = lambda *a: subprocess.run([abba, *a], check=True, capture_output=True, text=True)
    run("person", "new", "--db", db, "--name", name, "--tz", TZ, "--mode", "cgm", "--therapy-from", files[2])
    run("import", "--db", db, "--person", name, *files)
    t = time.perf_counter()
    out = subprocess.run([abba, "twin", "fit", "--db", db, "--person", name, "--days", str(days),
                          "--held-out", str(held_days), "--json"], capture_output=True, text=True)
    wall = time.perf_counter() - t
    if out.returncode != 0:
        return {"error": (out.stderr or out.stdout).strip()}, wall
    return json.loads(out.stdout), wall


# ------------------------------------------------------------------ scores


def scores(pred, obs):
    """RMSE and MARD of `pred` at the readings `obs` [(minute, mg/dL)], and
    the RMSE of the readings' own mean."""
    n = len(obs)
    err = [pred[m] - g for m, g in obs]
    rmse = math.sqrt(sum(e * e for e in err) / n)
    mard = 100.0 * sum(abs(e) / g for e, (_, g) in zip(err, obs)) / n
    mean = sum(g for _, g in obs) / n
    base = math.sqrt(sum((g - mean) ** 2 for _, g in obs) / n)
    return rmse, mard, base


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pump", required=True, help="CareLink CSV (or the merged copy, see README)")
    ap.add_argument("--libre", required=True, help="FreeStyle Libre CSV (or the merged copy)")
    ap.add_argument("--abba", default="target/release/abba")
    ap.add_argument("--fit-days", type=int, default=3)
    ap.add_argument("--held-out", type=int, default=1)
    ap.add_argument("--bw", type=float, default=70.0,
                    help="body weight for ReplayBG (kg); the exports do not hold it")
    ap.add_argument("--long-days", type=int, default=14,
                    help="abba also fitted on up to this many days ending with the same held-out days "
                         "(its default window), when the export has them")
    ap.add_argument("--persons", default="", help="comma-separated ids (default: all in the files)")
    ap.add_argument("--starts", type=int, default=0,
                    help="ReplayBG MAP starts (default: its own 128; fewer only for a quick look)")
    ap.add_argument("--skip-replaybg", action="store_true", help="abba only (for a quick look)")
    ap.add_argument("--out", default="target/replaybg-results.json")
    args = ap.parse_args()

    pumps, libres = hupa.split_merged(args.pump), hupa.split_merged(args.libre)
    if not pumps:  # one person's own file
        pumps = {"person": open(args.pump, encoding="utf-8").read().splitlines()}
        libres = {"person": open(args.libre, encoding="utf-8").read().splitlines()}
    ids = [p for p in sorted(pumps) if not args.persons or p in args.persons.split(",")]
    days = args.fit_days + args.held_out
    results = []
    print("| window | fit days | held-out readings | mean-glucose RMSE | ReplayBG RMSE / MARD | abba RMSE / MARD "
          "| ReplayBG fit (s) | abba fit (s) | abba, N days before: RMSE / MARD |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for pid in ids:
        if pid not in libres:
            print(f"{pid}: no Libre export, skipped", file=sys.stderr)
            continue
        pump = hupa.read_pump(pumps[pid], f"{args.pump} ({pid})")
        libre, food = hupa.read_libre(libres[pid], f"{args.libre} ({pid})")
        full = hupa.full_days(pump, libre)
        run_days = None
        for i in range(len(full) - days, -1, -1):
            if (full[i + days - 1] - full[i]).days == days - 1:
                run_days = full[i]
                break
        if run_days is None:
            print(f"{pid}: fewer than {days} consecutive full days, skipped", file=sys.stderr)
            continue
        rec = hupa.Record(pump, libre, run_days, days)
        first = run_days
        while (first - dt.timedelta(days=1)) in full and (run_days - first).days + days < args.long_days:
            first -= dt.timedelta(days=1)
        held = [(m - args.fit_days * 1440, g) for m, g in rec.glucose if m >= args.fit_days * 1440]
        row = {"person": pid, "replaybg_starts": args.starts or 128, "first_day": str(run_days), "fit_days": args.fit_days, "held_out_days": args.held_out,
               "held_out_readings": len(held), "libre_food_rows_unused": food,
               "carbs_g_per_day": sum(rec.carbs_g) / days, "insulin_u_per_day":
               (sum(rec.bolus_u) + sum(rec.basal_u_per_h) / 60.0) / days}
        with tempfile.TemporaryDirectory() as tmp:
            doc, abba_s = run_abba(args.abba, rec, args.fit_days, args.held_out, tmp, pid)
            row["abba_fit_s"] = abba_s
            if "error" in doc:
                row["abba_error"] = doc["error"]
            else:
                h = doc.get("held_out") or {}
                row["abba_rmse"] = h.get("rmse_mg_dl")
                row["abba_mard"] = h.get("mard_pct")
                row["abba_mean_glucose_rmse"] = h.get("mean_glucose_rmse_mg_dl")
                row["abba_readings"] = h.get("readings")
                row["abba_fit_rmse"] = doc["fit"]["rmse_mg_dl"]
                row["abba_simulations"] = doc["fit"]["simulations"]
                row["abba_found_meals"] = len(doc.get("found_meals") or [])
                row["abba_grade"] = doc.get("grade")
                row["abba_grade_reason"] = doc.get("grade_reason")
                if doc.get("held_out_error"):
                    row["abba_error"] = doc["held_out_error"]
            if first < run_days:
                long_rec = hupa.Record(pump, libre, first, (run_days - first).days + days)
                long_fit = long_rec.days - args.held_out
                with tempfile.TemporaryDirectory() as tmp2:
                    ldoc, ls = run_abba(args.abba, long_rec, long_fit, args.held_out, tmp2, pid)
                lh = ldoc.get("held_out") or {}
                row.update({"abba_long_fit_days": long_fit, "abba_long_rmse": lh.get("rmse_mg_dl"),
                            "abba_long_mard": lh.get("mard_pct"), "abba_long_fit_s": ls,
                            "abba_long_readings": lh.get("readings"), "abba_long_error": ldoc.get("error")})
            if not args.skip_replaybg:
                pred, fit_s, replay_s = run_replaybg(rec, args.fit_days, args.held_out, args.bw, tmp, args.starts)
                rmse, mard, base = scores(pred, held)
                row.update({"replaybg_rmse": rmse, "replaybg_mard": mard, "replaybg_fit_s": fit_s,
                            "replaybg_replay_s": replay_s})
            mean = sum(g for _, g in held) / len(held)
            row["mean_glucose_rmse"] = math.sqrt(sum((g - mean) ** 2 for _, g in held) / len(held))
        results.append(row)
        f = lambda k, fmt="{:.1f}": fmt.format(row[k]) if isinstance(row.get(k), (int, float)) else "-"
        last_fit = run_days + dt.timedelta(days=args.fit_days - 1)
        print(f"| {pid} | {run_days:%m-%d}..{last_fit:%m-%d} | {len(held)} | {f('mean_glucose_rmse')} "
              f"| {f('replaybg_rmse')} / {f('replaybg_mard')} % | {f('abba_rmse')} / {f('abba_mard')} % "
              f"| {f('replaybg_fit_s', '{:.0f}')} | {f('abba_fit_s')} "
              f"| {row.get('abba_long_fit_days', '-')}: {f('abba_long_rmse')} / {f('abba_long_mard')} % |", flush=True)
        if "abba_error" in row:
            print(f"  abba twin fit failed: {row['abba_error']}", flush=True)
        # Written after every window: a long run stopped early keeps its rows.
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as fo:
            json.dump(results, fo, indent=1, default=str)
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
