#!/usr/bin/env python3
"""Builds the inputs of the oref0 autotune reproduction fixture.

Glucose, meals and meal boluses come from `abba export` (a simulated
patient, adult#001, standard therapy, Europe/Zurich); this script turns them
into what a looping pump user's Nightscout holds, so that oref0's every path
is exercised:

- sgv values rounded to whole mg/dL (real CGMs report integers);
- an hourly-varying pump basal schedule (night, dawn, day, evening);
- temporary basals every 30 min (rate = scheduled rate scaled by how far
  glucose is from 110 mg/dL, rounded to 0.05 U/h, durations 20-60 min drawn
  from a fixed-seed generator, so that some run into the next temp and some
  cross an hour boundary), uploaded with `rate`, `absolute` and `duration`
  as OpenAPS does;
- one correction bolus a day.

The temps are NOT what the simulated patient received: the glucose does not
respond to them. The fixture checks arithmetic (our implementation against
oref0's on the same inputs), not physiology.

Usage: make_fixture.py EXPORT_DIR OUT_DIR
"""
import json
import random
import sys
from datetime import datetime, timedelta, timezone
from zoneinfo import ZoneInfo

TZ = ZoneInfo("Europe/Zurich")
# Day 1 of the fixture: local 04:00 of DAY to 04:00 of the next day (the
# window oref0-autotune.sh downloads for a day); DAY2 is the next one.
DAYS = ["2026-01-10", "2026-01-11"]

BASAL = [(0, 0.9), (180, 1.1), (420, 1.25), (720, 1.0), (1080, 1.15), (1320, 0.95)]


def local_minute(ts):
    t = ts.astimezone(TZ)
    return t.hour * 60 + t.minute


def scheduled(ts):
    m = local_minute(ts)
    rate = BASAL[0][1]
    for start, r in BASAL:
        if start <= m:
            rate = r
    return rate


def iso(ts):
    return ts.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.000Z")


def main(src, out):
    entries = json.load(open(f"{src}/entries.json"))
    treatments = json.load(open(f"{src}/treatments.json"))
    rng = random.Random(26)
    glucose = {}
    for e in entries:
        e["sgv"] = int(round(e["sgv"]))
        glucose[e["date"]] = e["sgv"]
    first = datetime.fromisoformat(DAYS[0]).replace(tzinfo=TZ) - timedelta(hours=18)
    last = datetime.fromisoformat(DAYS[-1]).replace(tzinfo=TZ) + timedelta(hours=28)
    temps = []
    t = first
    n = 0
    while t < last:
        ms = int(t.timestamp() * 1000)
        g = glucose.get(ms, 110)
        rate = scheduled(t) * max(0.0, min(2.0, 1.0 + (g - 110) / 120.0))
        rate = round(rate / 0.05) * 0.05
        duration = rng.choice([20, 30, 30, 45, 60])
        n += 1
        temps.append({
            "_id": f"fixture-temp-{n:05d}",
            "eventType": "Temp Basal",
            "created_at": iso(t),
            "rate": round(rate, 2),
            "absolute": round(rate, 2),
            "duration": duration,
            "enteredBy": "abba-fixture",
        })
        t += timedelta(minutes=30)
    corrections = []
    for day in DAYS:
        at = datetime.fromisoformat(day).replace(tzinfo=TZ) + timedelta(hours=15, minutes=5)
        corrections.append({
            "_id": f"fixture-correction-{day}",
            "eventType": "Correction Bolus",
            "created_at": iso(at),
            "insulin": 1.2,
            "enteredBy": "abba-fixture",
        })
    for tr in treatments:
        tr["created_at"] = tr["created_at"].replace("Z", ".000Z")
    # Nightscout answers newest first.
    all_treatments = sorted(treatments + temps + corrections,
                            key=lambda x: x["created_at"], reverse=True)
    lo = int(first.timestamp() * 1000)
    hi = int(last.timestamp() * 1000)
    all_treatments = [x for x in all_treatments
                      if lo <= int(datetime.fromisoformat(x["created_at"].replace("Z", "+00:00")).timestamp() * 1000) <= hi]
    basalprofile = [{"i": i, "start": f"{m // 60:02d}:{m % 60:02d}:00", "minutes": m, "rate": r}
                    for i, (m, r) in enumerate(BASAL)]
    profile = {
        "min_5m_carbimpact": 8,
        "dia": 5,
        "curve": "rapid-acting",
        "useCustomPeakTime": False,
        "insulinPeakTime": 75,
        "autosens_max": 1.2,
        "autosens_min": 0.7,
        "carb_ratio": 10,
        "basalprofile": basalprofile,
        "isfProfile": {"units": "mg/dL", "user_preferred_units": "mg/dL", "sensitivities": [
            {"i": 0, "start": "00:00:00", "sensitivity": 45, "offset": 0, "x": 0, "endOffset": 1440}]},
        "timezone": "Europe/Zurich",
    }
    json.dump(profile, open(f"{out}/pumpprofile.json", "w"), indent=1)
    json.dump(all_treatments, open(f"{out}/treatments.json", "w"), indent=1)
    for k, day in enumerate(DAYS, 1):
        start = datetime.fromisoformat(day).replace(tzinfo=TZ) + timedelta(hours=4)
        end = start + timedelta(hours=24)
        lo = int(start.timestamp() * 1000)
        hi = int(end.timestamp() * 1000)
        day_entries = [e for e in entries if lo <= e["date"] <= hi]
        json.dump(day_entries, open(f"{out}/entries.day{k}.json", "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
