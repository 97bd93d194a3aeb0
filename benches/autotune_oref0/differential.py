#!/usr/bin/env python3
"""Differential check of `abba autotune` against oref0 0.7.1 on random days.

Usage: differential.py ABBA_BINARY FIRST_CASE N_CASES [OREF0_BIN_DIR]

OREF0_BIN_DIR defaults to ./node_modules/oref0/bin (`npm install --no-save
oref0@0.7.1`; node on the PATH). Each case draws, from its own seed: a
simulated patient's export (`abba export`: adult#001-#010, arm, time zone,
start date), 1-3 days to tune, a pump profile (1-8 basal segments, ISF,
carb ratio, DIA, curve, custom peak, autosens caps, min_5m_carbimpact),
OpenAPS-style temporary basals every 5-60 min, correction boluses and gaps
in the CGM data. oref0 runs as oref0-autotune.sh runs it (prep, then core,
day by day, each day's entries from local midnight + 4 h to + 28 h in hours
elapsed); abba tunes the same days from all the files at once. A case prints
"ok" when every hourly basal is within 0.005 U/h and the ISF and carb ratio
within 0.5 % of oref0's, else DIFF with the differences. The data are
generated, not a person's; the temps do not act on the simulated glucose (the
check is the arithmetic). Cases whose days reach past today or whose random
gaps cut a day's end are refused by abba, as they should be.
abba is research software, not a medical device.
"""
import json, os, random, subprocess, sys
from datetime import datetime, timedelta, timezone, date
from zoneinfo import ZoneInfo

OREF = "node_modules/oref0/bin"
ZONES = ["Europe/Zurich", "America/New_York", "America/Los_Angeles", "Asia/Kolkata",
         "Australia/Sydney", "UTC", "Pacific/Auckland", "America/Sao_Paulo", "Asia/Tokyo"]


def iso(ts):
    return ts.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.000Z")


def hhmm(m):
    return f"{m // 60:02d}:{m % 60:02d}:00"


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


def case(abba, k):
    rng = random.Random(1000 + k)
    pop = "adult"
    patient = f"{pop}#{rng.randint(1, 10):03d}"
    arm = rng.choice(["standard", "abba", "r2r"])
    zone = rng.choice(ZONES)
    tz = ZoneInfo(zone)
    start = date(2026, 1, 5) + timedelta(days=rng.randint(0, 330))
    ndays = rng.choice([1, 2, 3])
    work = os.path.abspath(f"differential/case{k}")
    os.makedirs(work, exist_ok=True)
    exp = f"{work}/export"
    r = run([abba, "export", "--patient", patient, "--days", str(ndays + 9), "--arm", arm,
             "--tz", zone, "--start", start.isoformat(), "--out", exp])
    if r.returncode != 0:
        return ("export-failed", r.stderr[-300:])
    entries = json.load(open(f"{exp}/entries.json"))
    treatments = json.load(open(f"{exp}/treatments.json"))
    # CGM: whole mg/dL, random gaps.
    gaps = [(rng.randint(0, len(entries)), rng.randint(3, 40)) for _ in range(rng.randint(0, 4))]
    drop = set()
    for at, n in gaps:
        drop.update(range(at, at + n))
    entries = [e for i, e in enumerate(entries) if i not in drop]
    for e in entries:
        e["sgv"] = int(round(e["sgv"]))
    glucose = {e["date"]: e["sgv"] for e in entries}
    # Pump basal schedule.
    scale = rng.choice([1.0, 0.8, 0.45])
    nseg = rng.randint(1, 8)
    starts = sorted(set([0] + [rng.randrange(1, 48) * 30 for _ in range(nseg - 1)]))
    basal = [(m, round(max(0.05, scale * rng.uniform(0.5, 1.6)) / 0.05) * 0.05) for m in starts]
    basal = [(m, round(r, 2)) for m, r in basal]

    def scheduled(ts):
        t = ts.astimezone(tz)
        m = t.hour * 60 + t.minute
        rate = basal[0][1]
        for s, r in basal:
            if s <= m:
                rate = r
        return rate

    days = [start + timedelta(days=8 + i) for i in range(ndays)]
    first = datetime.combine(days[0], datetime.min.time()).replace(tzinfo=tz) - timedelta(hours=18)
    last = datetime.combine(days[-1], datetime.min.time()).replace(tzinfo=tz) + timedelta(hours=28)
    temps = []
    t = first
    n = 0
    every = rng.choice([5, 15, 30, 30, 60])
    temp_gain = rng.uniform(60, 200)
    while t < last:
        ms = int(t.timestamp() * 1000)
        g = glucose.get(ms, 110)
        rate = scheduled(t) * max(0.0, min(2.5, 1.0 + (g - 110) / temp_gain))
        rate = round(rate / 0.05) * 0.05
        duration = rng.choice([20, 30, 30, 45, 60, 120])
        n += 1
        if rng.random() > 0.05:
            temps.append({"_id": f"t{n:05d}", "eventType": "Temp Basal", "created_at": iso(t),
                          "rate": round(rate, 2), "absolute": round(rate, 2), "duration": duration,
                          "enteredBy": "openaps://fuzz"})
        t += timedelta(minutes=every)
    extra = []
    for day in days:
        for _ in range(rng.randint(0, 3)):
            at = datetime.combine(day, datetime.min.time()).replace(tzinfo=tz) + timedelta(minutes=rng.randint(0, 1439))
            extra.append({"_id": f"c{len(extra)}", "eventType": "Correction Bolus", "created_at": iso(at),
                          "insulin": round(rng.uniform(0.2, 3.0), 1), "enteredBy": "fuzz"})
    for tr in treatments:
        tr["created_at"] = tr["created_at"].replace("Z", ".000Z") if "." not in tr["created_at"] else tr["created_at"]
    allt = sorted(treatments + temps + extra, key=lambda x: x["created_at"], reverse=True)
    lo, hi = int(first.timestamp() * 1000), int(last.timestamp() * 1000)

    def ms_of(x):
        return int(datetime.fromisoformat(x["created_at"].replace("Z", "+00:00")).timestamp() * 1000)
    allt = [x for x in allt if lo <= ms_of(x) <= hi]
    curve = rng.choice(["rapid-acting", "rapid-acting", "ultra-rapid", "bilinear"])
    custom = rng.random() < 0.4
    isf = round(rng.uniform(20, 150) / scale ** 0.5)
    cr = round(rng.uniform(4, 25) / scale, 1)
    profile = {
        "min_5m_carbimpact": rng.choice([3, 8, 8, 12]),
        "dia": rng.choice([3, 4, 5, 5, 6, 7]),
        "curve": curve,
        "useCustomPeakTime": custom,
        "insulinPeakTime": rng.randint(35, 120) if custom else 75,
        "autosens_max": rng.choice([1.2, 1.2, 1.5, 2.0]),
        "autosens_min": rng.choice([0.7, 0.7, 0.5, 0.9]),
        "carb_ratio": cr,
        "basalprofile": [{"i": i, "start": hhmm(m), "minutes": m, "rate": r} for i, (m, r) in enumerate(basal)],
        "isfProfile": {"units": "mg/dL", "user_preferred_units": "mg/dL", "sensitivities": [
            {"i": 0, "start": "00:00:00", "sensitivity": isf, "offset": 0, "x": 0, "endOffset": 1440}]},
        "timezone": zone,
    }
    json.dump(profile, open(f"{work}/pumpprofile.json", "w"), indent=1)
    json.dump(allt, open(f"{work}/treatments.json", "w"), indent=1)
    allents = []
    env = dict(os.environ, TZ=zone)
    cur = f"{work}/profile.json"
    json.dump(profile, open(cur, "w"))
    for i, day in enumerate(days):
        s = datetime.combine(day, datetime.min.time()).replace(tzinfo=tz).astimezone(timezone.utc) + timedelta(hours=4)
        e = s + timedelta(hours=24)
        de = sorted([x for x in entries if int(s.timestamp() * 1000) <= x["date"] <= int(e.timestamp() * 1000)],
                    key=lambda x: -x["date"])
        allents += de
        json.dump(de, open(f"{work}/entries.day{i}.json", "w"))
        r1 = run(["node", f"{OREF}/oref0-autotune-prep.js", f"{work}/treatments.json", cur,
                  f"{work}/entries.day{i}.json", f"{work}/pumpprofile.json"], env=env)
        if r1.returncode != 0 or not r1.stdout.strip():
            return ("oref0-prep-failed", r1.stderr[-300:])
        open(f"{work}/prepped.day{i}.json", "w").write(r1.stdout)
        r2 = run(["node", f"{OREF}/oref0-autotune-core.js", f"{work}/prepped.day{i}.json", cur,
                  f"{work}/pumpprofile.json"], env=env)
        if r2.returncode != 0 or not r2.stdout.strip():
            return ("oref0-core-failed", r2.stderr[-300:])
        open(f"{work}/autotune.day{i}.json", "w").write(r2.stdout)
        cur = f"{work}/autotune.day{i}.json"
    want = json.load(open(cur))
    uniq = {x["date"]: x for x in allents}
    json.dump(sorted(uniq.values(), key=lambda x: -x["date"]), open(f"{work}/entries.json", "w"))
    r = run([abba, "autotune", "--entries", f"{work}/entries.json", "--treatments", f"{work}/treatments.json",
             "--profile", f"{work}/pumpprofile.json", "--pump-profile", f"{work}/pumpprofile.json",
             "--tz", zone, "--start", days[0].isoformat(), "--end", days[-1].isoformat(), "--json"])
    if r.returncode != 0:
        return ("abba-failed", r.stderr[-600:])
    got = json.loads(r.stdout)["profile"]
    bad = []
    gb = {b["minutes"]: b["rate"] for b in got["basalprofile"]}
    for b in want["basalprofile"]:
        g = gb.get(b["minutes"])
        if g is None or abs(g - b["rate"]) > 0.005:
            bad.append(f"basal {b['minutes']}: {g} vs {b['rate']}")
    gi = got["isfProfile"]["sensitivities"][0]["sensitivity"]
    wi = want["isfProfile"]["sensitivities"][0]["sensitivity"]
    if abs(gi / wi - 1) > 0.005:
        bad.append(f"isf {gi} vs {wi}")
    if abs(got["carb_ratio"] / want["carb_ratio"] - 1) > 0.005:
        bad.append(f"cr {got['carb_ratio']} vs {want['carb_ratio']}")
    desc = f"{patient} {arm} {zone} {days[0]} x{ndays} {curve} dia {profile['dia']} peak {profile['insulinPeakTime'] if custom else '-'} every {every}"
    return ("ok" if not bad else "DIFF", desc + ("; " + "; ".join(bad[:6]) if bad else ""))


if __name__ == "__main__":
    abba, k0, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    if len(sys.argv) > 4:
        OREF = sys.argv[4]
    for k in range(k0, k0 + n):
        status, msg = case(abba, k)
        print(k, status, msg, flush=True)
