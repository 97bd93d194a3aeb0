#!/bin/sh
# Regenerates crates/advisor/tests/data/autotune_oref0/ (see README.md there).
# Needs node (20 used) and network access to the npm registry once.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
data="$repo/crates/advisor/tests/data/autotune_oref0"
work=${WORK:-$(mktemp -d)}
mkdir -p "$data"
(cd "$work" && [ -d node_modules/oref0 ] || npm install --no-save oref0@0.7.1 >/dev/null)
bin="$work/node_modules/oref0/bin"
rm -rf "$work/export"
(cd "$repo" && cargo run -q --release -p abba -- export --patient adult#001 --days 9 \
    --arm standard --tz Europe/Zurich --out "$work/export")
python3 "$here/make_fixture.py" "$work/export" "$data"
export TZ=Europe/Zurich
# One day as oref0-autotune.sh runs it: oref0-autotune-prep on the
# treatments ($1) and entries ($2) with the profile tuned so far
# ($work/profile.json) to $3, then oref0-autotune-core to $4, which becomes
# the profile tuned so far. The pump profile is the fixture's.
oref0_day() {
  node "$bin/oref0-autotune-prep.js" "$1" "$work/profile.json" "$2" "$data/pumpprofile.json" > "$3" 2>/dev/null
  node "$bin/oref0-autotune-core.js" "$3" "$work/profile.json" "$data/pumpprofile.json" > "$4" 2>/dev/null
  cp "$4" "$work/profile.json"
}
cp "$data/pumpprofile.json" "$work/profile.json"
for day in 1 2; do
  cp "$work/profile.json" "$data/profile.day$day.json"
  oref0_day "$data/treatments.json" "$data/entries.day$day.json" \
    "$data/prepped.day$day.json" "$data/autotune.day$day.json"
done
# The same days in the forms real uploaders store them (make_quirks.py).
python3 "$here/make_quirks.py" "$data" "$data"
cp "$data/pumpprofile.json" "$work/profile.json"
for day in 1 2; do
  oref0_day "$data/treatments.quirks.json" "$data/entries.quirks.day$day.json" \
    "$work/prepped.quirks.day$day.json" "$data/autotune.quirks.day$day.json"
done
# The quirk days moved onto the days the clocks change (shift_days.py):
# spring forward (2026-03-28/29) and fall back (2026-10-24/25).
for change in spring:77:2026-03-28 autumn:287:2026-10-24; do
  name=${change%%:*}; rest=${change#*:}; by=${rest%%:*}; first=${rest#*:}
  python3 "$here/shift_days.py" "$data" "$by" "$first" "$work/$name"
  cp "$data/pumpprofile.json" "$work/profile.json"
  for day in 1 2; do
    oref0_day "$work/$name/treatments.day$day.json" "$work/$name/entries.day$day.json" \
      "$work/$name/prepped.day$day.json" "$work/$name/autotune.day$day.json"
  done
  cp "$work/profile.json" "$data/autotune.quirks.$name.day2.json"
done
echo "wrote $data"
