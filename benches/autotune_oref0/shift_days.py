#!/usr/bin/env python3
"""Moves the oref0 fixture's quirk days (make_quirks.py's files) by whole
days, to days on which the clocks change (Europe/Zurich: 2026-03-29 and
2026-10-25), and cuts the entries at local 04:00 as oref0-autotune.sh
downloads a day.

Every instant moves by the same number of days (the data stay the same
hours apart); every text instant is written in UTC (`...Z`, milliseconds),
as crates/cli/tests/autotune_cli.rs moves them.

Usage: shift_days.py FIXTURE_DIR DAYS FIRST_DAY OUT_DIR
(writes treatments.json, entries.json and entries.day{1,2}.json to OUT_DIR;
FIRST_DAY is the first moved day, YYYY-MM-DD)
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


def four_am(day):
    return int(datetime(day.year, day.month, day.day, 4, tzinfo=TZ).timestamp() * 1000)


def main(src, days, first, out):
    by = timedelta(days=int(days))
    os.makedirs(out, exist_ok=True)
    treatments = [move(t, by) for t in json.load(open(f"{src}/treatments.quirks.json"))]
    json.dump(treatments, open(f"{out}/treatments.json", "w"))
    entries = [move(e, by) for d in (1, 2) for e in json.load(open(f"{src}/entries.quirks.day{d}.json"))]
    json.dump(entries, open(f"{out}/entries.json", "w"))
    day = date.fromisoformat(first)
    for k in (1, 2):
        lo, hi = four_am(day), four_am(day + timedelta(days=1))
        json.dump([e for e in entries if lo <= e["date"] <= hi], open(f"{out}/entries.day{k}.json", "w"))
        day += timedelta(days=1)


if __name__ == "__main__":
    main(*sys.argv[1:])
