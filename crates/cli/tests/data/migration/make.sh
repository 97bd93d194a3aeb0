#!/usr/bin/env bash
# Makes a store with a released abba binary, for the migration test
# (tests/store_migration.rs): every kind of row a person's store holds,
# written by that release's own code, and what that release answered for
# it (advise and history as JSON, the persons, the app's held events).
#
#   make.sh OLD_ABBA REVISION OUT_DIR
#
# REVISION: the git commit OLD_ABBA was built from (written to made-by.txt).
#
# Kept so that the fixture can be made again with another release; its
# output is committed (see PROVENANCE.md beside this script). Not run by
# the tests. abba is research software, not a medical device.
set -euo pipefail
A="$(realpath "$1")"
rev="$2"
out="$3"
mkdir -p "$out"
work=$(mktemp -d)
trap 'kill $srv 2>/dev/null || true; rm -rf "$work"' EXIT
db="$work/store.db"

# 1. A person from a Nightscout export: persons, imports, the record log,
#    a clinician's change of therapy.
"$A" export --patient adult#002 --days 12 --tz Europe/Zurich --out "$work/ns" >/dev/null
"$A" person new --db "$db" --name ana --tz Europe/Zurich --mode cgm --basal 1.0 \
  --carb-ratio 10,12,11 --basal-range 0.8-1.6 --carb-ratio-range 6-14 >/dev/null
"$A" import --db "$db" --person ana --adopt-profile \
  "$work/ns/entries.json" "$work/ns/treatments.json" "$work/ns/profile.json" >/dev/null
"$A" therapy set --db "$db" --person ana --basal 00:00=1.3,06:00=1.4 --carb-ratio 8,8.1,8.1 \
  --at 2026-01-15T00:00 >/dev/null

# 2. A person whose pump app talks to the service: tokens, the app's
#    events with their sequence numbers, suggestions and answers, the
#    live advisor's snapshots.
admin=$("$A" token --db "$db" --admin)
"$A" serve --db "$db" --listen 127.0.0.1:0 >"$work/serve.log" 2>&1 &
srv=$!
url=""
for _ in $(seq 100); do
  url=$(grep -so 'http://127\.0\.0\.1:[0-9]*' "$work/serve.log" | head -1 || true)
  [ -n "$url" ] && break
  sleep 0.1
done
"$A" app --url "$url" --token "$admin" --patient adult#005 --scenario S2 --days 14 --name ben >/dev/null
kill $srv; wait $srv 2>/dev/null || true

# 3. A person token and a one-time sign-in link for the web pages.
"$A" token --db "$db" --person ana >/dev/null
"$A" token --db "$db" --person ana --signin >/dev/null 2>&1 || true

# Every connection is closed: SQLite has checkpointed its journal into
# the file, so the file alone is the store.
if [ -s "$db-wal" ]; then echo "a journal is left beside $db" >&2; exit 1; fi
cp "$db" "$out/store.db"
python3 - "$db" >"$out/tables.txt" <<'PY'
import sqlite3, sys
c = sqlite3.connect(sys.argv[1])
for (t,) in c.execute("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name"):
    print(t, c.execute(f'SELECT count(*) FROM "{t}"').fetchone()[0])
PY
echo "$admin" >"$out/admin.token"
for p in ana ben; do
  "$A" advise --db "$db" --person "$p" --json >"$out/$p.advise.json"
  "$A" history --db "$db" --person "$p" --json >"$out/$p.history.json"
done
"$A" person list --db "$db" >"$out/persons.txt"
echo "abba at $rev, schema version $(python3 -c 'import sqlite3,sys; print(sqlite3.connect(sys.argv[1]).execute("PRAGMA user_version").fetchone()[0])' "$db")" >"$out/made-by.txt"
