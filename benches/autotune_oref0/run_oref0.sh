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
cp "$data/pumpprofile.json" "$work/profile.json"
for day in 1 2; do
  node "$bin/oref0-autotune-prep.js" "$data/treatments.json" "$work/profile.json" \
      "$data/entries.day$day.json" "$data/pumpprofile.json" > "$data/prepped.day$day.json" 2>/dev/null
  cp "$work/profile.json" "$data/profile.day$day.json"
  node "$bin/oref0-autotune-core.js" "$data/prepped.day$day.json" "$work/profile.json" \
      "$data/pumpprofile.json" > "$data/autotune.day$day.json" 2>/dev/null
  cp "$data/autotune.day$day.json" "$work/profile.json"
done
# The same days in the forms real uploaders store them (make_quirks.py).
python3 "$here/make_quirks.py" "$data" "$data"
cp "$data/pumpprofile.json" "$work/profile.json"
for day in 1 2; do
  node "$bin/oref0-autotune-prep.js" "$data/treatments.quirks.json" "$work/profile.json" \
      "$data/entries.quirks.day$day.json" "$data/pumpprofile.json" > "$work/prepped.quirks.day$day.json" 2>/dev/null
  node "$bin/oref0-autotune-core.js" "$work/prepped.quirks.day$day.json" "$work/profile.json" \
      "$data/pumpprofile.json" > "$data/autotune.quirks.day$day.json" 2>/dev/null
  cp "$data/autotune.quirks.day$day.json" "$work/profile.json"
done
# The quirk days moved onto the days the clocks change (shift_days.py):
# spring forward (2026-03-28/29) and fall back (2026-10-24/25).
for change in spring:77:2026-03-28 autumn:287:2026-10-24; do
  name=${change%%:*}; rest=${change#*:}; by=${rest%%:*}; first=${rest#*:}
  python3 "$here/shift_days.py" "$data" "$by" "$first" "$work/$name"
  cp "$data/pumpprofile.json" "$work/profile.json"
  for day in 1 2; do
    node "$bin/oref0-autotune-prep.js" "$work/$name/treatments.day$day.json" "$work/profile.json" \
        "$work/$name/entries.day$day.json" "$data/pumpprofile.json" > "$work/$name/prepped.day$day.json" 2>/dev/null
    node "$bin/oref0-autotune-core.js" "$work/$name/prepped.day$day.json" "$work/profile.json" \
        "$data/pumpprofile.json" > "$work/profile.next.json" 2>/dev/null
    mv "$work/profile.next.json" "$work/profile.json"
  done
  cp "$work/profile.json" "$data/autotune.quirks.$name.day2.json"
done
echo "wrote $data"
