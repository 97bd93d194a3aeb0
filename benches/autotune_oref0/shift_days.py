#!/usr/bin/env python3
"""Moves the oref0 fixture's quirk days (make_quirks.py's files) by whole
days, to days on which the clocks change (Europe/Zurich: 2026-03-29 and
2026-10-25), and cuts each day's files as oref0-autotune.sh downloads them:
entries from local midnight + 4 h to + 28 h, treatments by `created_at`
from midnight - 18 h to + 42 h (GNU `date -d "DAY +4 hours"`: hours
elapsed, so a day on which the clocks change starts at 05:00 or 03:00).

Every instant moves by the same number of days (the data stay the same
hours apart); every text instant is written in UTC (`...Z`, milliseconds),
as crates/cli/tests/autotune_cli.rs moves them.

Usage: shift_days.py FIXTURE_DIR DAYS FIRST_DAY OUT_DIR
(writes treatments.json and entries.json, all of them, and each day's
treatments.day{1,2}.json and entries.day{1,2}.json to OUT_DIR; FIRST_DAY is
the first moved day, YYYY-MM-DD)
"""
import json
import os
import sys
from datetime import date, datetime, timedelta, timezone
from zoneinfo import ZoneInfo

TZ = ZoneInfo("Europe/Zurich")
TEXT = ("created_at", "timestamp", "dateString", "sysTime")


def moved(text, by):
    t = datetime.fromisoformat(text.replace("Z", "+00:00")) + by
    return t.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"


def move(item, by):
    for k in TEXT:
        if isinstance(item.get(k), str):
            item[k] = moved(item[k], by)
    if isinstance(item.get("date"), (int, float)):
        item["date"] = int(item["date"] + by.total_seconds() * 1000)
    return item


def midnight_plus(day, hours):
    """ms of local midnight of `day` plus `hours` elapsed."""
    midnight = datetime(day.year, day.month, day.day, tzinfo=TZ).astimezone(timezone.utc)
    return int((midnight + timedelta(hours=hours)).timestamp() * 1000)


def ms_of(text):
    return int(datetime.fromisoformat(text.replace("Z", "+00:00")).timestamp() * 1000)


def main(src, days, first, out):
    by = timedelta(days=int(days))
    os.makedirs(out, exist_ok=True)
    treatments = [move(t, by) for t in json.load(open(f"{src}/treatments.quirks.json"))]
    json.dump(treatments, open(f"{out}/treatments.json", "w"))
    entries = [move(e, by) for d in (1, 2) for e in json.load(open(f"{src}/entries.quirks.day{d}.json"))]
    json.dump(entries, open(f"{out}/entries.json", "w"))
    day = date.fromisoformat(first)
    for k in (1, 2):
        lo, hi = midnight_plus(day, 4), midnight_plus(day, 28)
        json.dump([e for e in entries if lo <= e["date"] <= hi], open(f"{out}/entries.day{k}.json", "w"))
        lo, hi = midnight_plus(day, -18), midnight_plus(day, 42)
        json.dump([t for t in treatments if lo <= ms_of(t["created_at"]) <= hi],
                  open(f"{out}/treatments.day{k}.json", "w"))
        day += timedelta(days=1)


if __name__ == "__main__":
    main(*sys.argv[1:])
