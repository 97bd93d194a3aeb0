#!/usr/bin/env python3
"""Rewrites the oref0 fixture's Nightscout treatments and entries in the
forms real uploaders store them (crates/advisor/tests/data/autotune_oref0,
README.md there), so that `abba autotune` is checked against oref0 0.7.1 on
what a looping user's Nightscout holds, not only on one uploader's shape.

The same insulin and carbohydrate reach both programs; only the records'
shapes change, as AndroidAPS, Loop, an OpenAPS rig, xDrip+ and Nightscout's
Careportal upload them (field names from their Nightscout uploaders; no
person's data):

- temporary basals, in turn: OpenAPS (`rate`, `absolute`, `duration`,
  `temp`, a local `timestamp` with its offset beside `created_at`),
  AndroidAPS (`absolute` and `rate`, `durationInMilliseconds`, `date` in ms,
  `isValid`, `pumpId`, `enteredBy` openaps://AndroidAPS), Loop (`duration`
  in fractional minutes, the `amount` delivered in 0.05 U pulses, which
  oref0 takes over `rate`, `automatic`, `reason`), and AndroidAPS percent
  temps (`percent` beside `absolute`);
- meal boluses, in turn: Careportal "Meal Bolus" (insulin and carbs),
  "Bolus Wizard" (insulin and carbs), and Loop's separate "Carb Correction"
  (carbs) with a "Correction Bolus" (insulin) 40 s later;
- the same carbs uploaded twice within a second by a second uploader (oref0
  keeps one of carbs within 2 s of each other);
- AndroidAPS super-micro-boluses ("Correction Bolus", `isSMB`, `type` SMB)
  of 0.1-0.3 U beside some temps;
- records that carry neither insulin nor carbs: "Temporary Target", "Note",
  "Site Change", "Profile Switch", "Sensor Start", "Announcement";
- entries: every sgv with `direction`, `device`, `dateString` and `sysTime`;
  a second uploader's copy of every sixth reading (same `date`); meter
  readings (`type` mbg) and a calibration (`type` cal), which autotune does
  not use.

Usage: make_quirks.py FIXTURE_DIR OUT_DIR
(reads treatments.json and entries.day{1,2}.json of FIXTURE_DIR, writes
treatments.quirks.json and entries.quirks.day{1,2}.json to OUT_DIR)
"""
import json
import random
import sys
from datetime import datetime, timedelta, timezone

OFFSET = timedelta(hours=1)  # Europe/Zurich in January


def parse(text):
    return datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ").replace(tzinfo=timezone.utc)


def iso(ts):
    return ts.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.000Z")


def local(ts):
    return (ts + OFFSET).strftime("%Y-%m-%dT%H:%M:%S+01:00")


def ms(ts):
    return int(ts.timestamp() * 1000)


def temp(t, i):
    at = parse(t["created_at"])
    rate, minutes = t["rate"], t["duration"]
    form = i % 4
    if form == 0:  # OpenAPS rig
        return {"eventType": "Temp Basal", "duration": minutes, "rate": rate, "absolute": rate,
                "temp": "absolute", "timestamp": local(at), "created_at": iso(at),
                "enteredBy": "openaps://medtronic/723", "medtronic": "mm://openaps/mm-format-ns-treatments/Temp Basal"}
    if form == 1:  # AndroidAPS
        return {"eventType": "Temp Basal", "created_at": iso(at), "date": ms(at), "isValid": True,
                "duration": minutes, "durationInMilliseconds": minutes * 60000, "type": "NORMAL",
                "rate": rate, "absolute": rate, "pumpId": 40000 + i, "pumpType": "OMNIPOD_DASH",
                "pumpSerial": "4241", "utcOffset": 60, "enteredBy": "openaps://AndroidAPS"}
    if form == 2:  # Loop: fractional minutes, and the units delivered in pump pulses of 0.05 U
        ran = float(minutes) - (0.25 if i % 8 == 2 else 0.0)
        delivered = round(round(rate * ran / 60 / 0.05) * 0.05, 2)
        return {"eventType": "Temp Basal", "timestamp": iso(at), "created_at": iso(at), "temp": "absolute",
                "rate": rate, "absolute": rate, "duration": ran, "amount": delivered, "automatic": True,
                "reason": "Temp Basal", "enteredBy": "loop://iPhone", "syncIdentifier": f"tb{i:05d}"}
    # AndroidAPS percent temp (the absolute rate beside it)
    return {"eventType": "Temp Basal", "created_at": iso(at), "date": ms(at), "isValid": True,
            "duration": minutes, "durationInMilliseconds": minutes * 60000, "type": "NORMAL",
            "percent": -30, "rate": rate, "absolute": rate, "pumpId": 40000 + i,
            "enteredBy": "openaps://AndroidAPS"}


def meal(t, i):
    at = parse(t["created_at"])
    form = i % 3
    if form == 0:
        return [dict(t, eventType="Meal Bolus", enteredBy="careportal")]
    if form == 1:
        return [{"eventType": "Bolus Wizard", "created_at": iso(at), "insulin": t["insulin"],
                 "carbs": t["carbs"], "enteredBy": "careportal", "notes": "",
                 "bolusCalculatorResult": "{}"}]
    later = at + timedelta(seconds=40)
    return [{"eventType": "Carb Correction", "created_at": iso(at), "timestamp": iso(at),
             "carbs": t["carbs"], "absorptionTime": 180, "enteredBy": "loop://iPhone",
             "syncIdentifier": f"carb{i}"},
            {"eventType": "Correction Bolus", "created_at": iso(later), "timestamp": iso(later),
             "insulin": t["insulin"], "programmed": t["insulin"], "type": "normal",
             "duration": 0.2, "automatic": False, "enteredBy": "loop://iPhone"}]


def main(src, out):
    rng = random.Random(7)
    treatments = json.load(open(f"{src}/treatments.json"))
    result = []
    temps = meals = 0
    for t in treatments:
        kind = t["eventType"]
        if kind == "Temp Basal":
            result.append(temp(t, temps))
            if temps % 5 == 2:
                at = parse(t["created_at"]) + timedelta(minutes=3)
                result.append({"eventType": "Correction Bolus", "created_at": iso(at), "date": ms(at),
                               "insulin": round(rng.choice([0.1, 0.15, 0.2, 0.3]), 2), "type": "SMB",
                               "isSMB": True, "isValid": True, "pumpId": 50000 + temps,
                               "enteredBy": "openaps://AndroidAPS"})
            temps += 1
        elif "carbs" in t:
            made = meal(t, meals)
            result.extend(made)
            if meals % 4 == 1:
                # a second uploader's copy of the carbs, 600 ms later
                first = parse(made[0]["created_at"]) + timedelta(milliseconds=600)
                result.append({"eventType": "Carb Correction", "carbs": t["carbs"],
                               "created_at": first.strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z",
                               "enteredBy": "xDrip4iOS"})
            meals += 1
        else:
            result.append(dict(t))
    day0 = parse(treatments[-1]["created_at"])
    for k, (kind, extra) in enumerate([
        ("Temporary Target", {"targetTop": 140, "targetBottom": 140, "duration": 60, "reason": "Activity",
                              "units": "mg/dl"}),
        ("Note", {"notes": "walk"}),
        ("Site Change", {}),
        ("Profile Switch", {"profile": "Default", "duration": 0, "percentage": 100, "timeshift": 0}),
        ("Sensor Start", {}),
        ("Announcement", {"notes": "uploader restarted", "isAnnouncement": True}),
    ]):
        at = day0 + timedelta(hours=3 + 5 * k, minutes=7)
        result.append(dict({"eventType": kind, "created_at": iso(at), "enteredBy": "careportal"}, **extra))
    result.sort(key=lambda r: r["created_at"], reverse=True)
    json.dump(result, open(f"{out}/treatments.quirks.json", "w"), indent=1)

    for day in (1, 2):
        entries = json.load(open(f"{src}/entries.day{day}.json"))
        rows = []
        for n, e in enumerate(entries):
            at = datetime.fromtimestamp(e["date"] / 1000, timezone.utc)
            row = {"_id": f"q{day}{n:04d}", "device": "xDrip-DexcomG6", "date": e["date"],
                   "dateString": iso(at), "sysTime": iso(at), "sgv": e["sgv"],
                   "delta": 0.5, "direction": "Flat", "type": "sgv", "noise": 1, "utcOffset": 60}
            rows.append(row)
            if n % 6 == 3:
                rows.append(dict(row, _id=f"d{day}{n:04d}", device="share2", noise=0))
            if n % 48 == 10:
                rows.append({"_id": f"m{day}{n:04d}", "device": "careportal", "date": e["date"] + 60000,
                             "dateString": iso(at + timedelta(minutes=1)), "mbg": e["sgv"] + 4,
                             "type": "mbg"})
            if n == 100:
                rows.append({"_id": f"c{day}", "device": "xDrip-DexcomG6", "date": e["date"] + 1000,
                             "dateString": iso(at), "type": "cal", "slope": 1000, "intercept": 0, "scale": 1})
        rows.sort(key=lambda r: r["date"], reverse=True)
        json.dump(rows, open(f"{out}/entries.quirks.day{day}.json", "w"), indent=1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
