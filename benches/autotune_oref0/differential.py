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
# Cases draw bolus forms oref0 does not read (ABBA_DIFF_ODD=1).
ODD = os.environ.get("ABBA_DIFF_ODD") == "1"
ZONES = ["Europe/Zurich", "America/New_York", "America/Los_Angeles", "Asia/Kolkata",
         "Australia/Sydney", "UTC", "Pacific/Auckland", "America/Sao_Paulo", "Asia/Tokyo"]


def iso(ts):
    return ts.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.000Z")


def hhmm(m):
    return f"{m // 60:02d}:{m % 60:02d}:00"


def temp_form(rng, t, n, rate, minutes, tz):
    """A temporary basal as OpenAPS (rng None, or in turn), AndroidAPS
    (absolute or percent) or Loop (fractional minutes, `amount`) upload it."""
    base = {"_id": f"t{n:05d}", "eventType": "Temp Basal", "created_at": iso(t)}
    form = 0 if rng is None else rng.randrange(4)
    ms = int(t.timestamp() * 1000)
    if form == 0:
        return dict(base, rate=rate, absolute=rate, duration=minutes, temp="absolute",
                    timestamp=t.astimezone(tz).isoformat(), enteredBy="openaps://medtronic/723")
    if form == 1 or form == 3:
        doc = dict(base, date=ms, isValid=True, duration=minutes, durationInMilliseconds=minutes * 60000,
                   type="NORMAL", rate=rate, absolute=rate, pumpId=40000 + n, pumpType="OMNIPOD_DASH",
                   utcOffset=int(t.astimezone(tz).utcoffset().total_seconds() // 60),
                   enteredBy="openaps://AndroidAPS")
        if form == 3:
            doc["percent"] = -30
        return doc
    ran = float(minutes) - (0.25 if n % 8 == 2 else 0.0)
    delivered = round(round(rate * ran / 60 / 0.05) * 0.05, 2)
    return dict(base, timestamp=iso(t), temp="absolute", rate=rate, absolute=rate, duration=ran,
                amount=delivered, automatic=True, reason="Temp Basal", enteredBy="loop://iPhone",
                syncIdentifier=f"tb{n:05d}")


def bolus_form(rng, id_, at, units):
    """A correction bolus as Careportal's Correction Bolus, or (rng given,
    in turn) as uploads oref0 does not read insulin from: Trio's and iAPS's
    "Bolus", Careportal's "Combo Bolus" (now and extended parts) and its
    default "<none>"."""
    base = {"_id": id_, "created_at": iso(at), "insulin": units, "enteredBy": "fuzz"}
    form = 0 if rng is None else rng.randrange(4)
    if form == 0:
        return dict(base, eventType="Correction Bolus")
    if form == 1:
        return dict(base, eventType="Bolus", type="normal", isSMB=False, enteredBy="Trio")
    if form == 2:
        ext = round(units * 0.4, 1)
        return dict(base, eventType="Combo Bolus", insulin=round(units - ext, 2), enteredinsulin=units,
                    splitNow=60, splitExt=40, relative=round(ext * 2, 2), duration=30, enteredBy="careportal")
    return dict(base, eventType="<none>", enteredBy="careportal")


def meal_form(rng, tr, i):
    """A meal as Careportal's Meal Bolus, a Bolus Wizard, or Loop's carbs
    apart from their bolus (40 s later)."""
    form = rng.randrange(3)
    if form == 0 or "carbs" not in tr:
        return [tr]
    if form == 1:
        return [dict(tr, eventType="Bolus Wizard", enteredBy="careportal", bolusCalculatorResult="{}")]
    at = datetime.fromisoformat(tr["created_at"].replace("Z", "+00:00"))
    later = at + timedelta(seconds=40)
    return [{"_id": f"carb{i}", "eventType": "Carb Correction", "created_at": iso(at), "timestamp": iso(at),
             "carbs": tr["carbs"], "absorptionTime": 180, "enteredBy": "loop://iPhone"},
            {"_id": f"bolus{i}", "eventType": "Correction Bolus", "created_at": iso(later),
             "timestamp": iso(later), "insulin": tr["insulin"], "programmed": tr["insulin"],
             "type": "normal", "automatic": False, "enteredBy": "loop://iPhone"}]


def isf_schedule(rng, isf):
    """One to three ISF segments (oref0 categorises by the ISF in force)."""
    starts = sorted(set([0] + [rng.randrange(1, 48) * 30 for _ in range(rng.randrange(3))]))
    out = []
    for i, m in enumerate(starts):
        end = starts[i + 1] if i + 1 < len(starts) else 1440
        out.append({"i": i, "start": hhmm(m), "sensitivity": isf if i == 0 else round(isf * rng.uniform(0.7, 1.3)),
                    "offset": m, "x": i, "endOffset": end})
    return out


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
    forms = rng.random() < 0.5
    odd = ODD and rng.random() < 0.7
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
            temps.append(temp_form(rng if forms else None, t, n, round(rate, 2), duration, tz))
            if forms and rng.random() < 0.1:  # an SMB after the temp
                at = t + timedelta(minutes=2)
                temps.append({"_id": f"s{n:05d}", "eventType": "Correction Bolus", "created_at": iso(at),
                              "date": int(at.timestamp() * 1000), "insulin": rng.choice([0.1, 0.15, 0.2, 0.3]),
                              "type": "SMB", "isSMB": True, "isValid": True, "pumpId": 50000 + n,
                              "enteredBy": "openaps://AndroidAPS"})
            if forms and rng.random() < 0.05:  # a cancel (a zero-minute temp)
                at = t + timedelta(minutes=every // 2 or 1)
                temps.append({"_id": f"x{n:05d}", "eventType": "Temp Basal", "created_at": iso(at),
                              "rate": 0, "absolute": 0, "duration": 0, "enteredBy": "openaps://fuzz"})
        t += timedelta(minutes=every)
    extra = []
    for day in days:
        for _ in range(rng.randint(0, 3)):
            at = datetime.combine(day, datetime.min.time()).replace(tzinfo=tz) + timedelta(minutes=rng.randint(0, 1439))
            extra.append(bolus_form(rng if odd else None, f"c{len(extra)}", at, round(rng.uniform(0.2, 3.0), 1)))
    for tr in treatments:
        tr["created_at"] = tr["created_at"].replace("Z", ".000Z") if "." not in tr["created_at"] else tr["created_at"]
    if forms:
        treatments = [x for i, tr in enumerate(treatments) for x in meal_form(rng, tr, i)]
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
        "isfProfile": {"units": "mg/dL", "user_preferred_units": "mg/dL", "sensitivities": isf_schedule(rng, isf)},
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
    desc = f"{patient} {arm} {zone} {days[0]} x{ndays} {'forms ' if forms else ''}{'odd ' if odd else ''}isf x{len(profile['isfProfile']['sensitivities'])} {curve} dia {profile['dia']} peak {profile['insulinPeakTime'] if custom else '-'} every {every}"
    return ("ok" if not bad else "DIFF", desc + ("; " + "; ".join(bad[:6]) if bad else ""))


if __name__ == "__main__":
    abba, k0, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    if len(sys.argv) > 4:
        OREF = sys.argv[4]
    for k in range(k0, k0 + n):
        status, msg = case(abba, k)
        print(k, status, msg, flush=True)
