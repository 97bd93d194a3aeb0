#!/usr/bin/env bash
# The service under load on each backend (issue 30): one `abba serve` on a
# fresh SQLite file, one on a fresh PostgreSQL database, and two replicas
# on one PostgreSQL database with the load example's clients spread over
# them (client i talks to replica i mod 2, as a balancer would). Each line
# is `crates/client/examples/load.rs` for SECONDS against a fresh store.
#
#   benches/service_load/run.sh POSTGRES_URL [SECONDS]
#
# POSTGRES_URL: a server this script may create databases on, for example
# `postgresql:///abba?host=/tmp/pg&port=5432&user=abba` (the user needs
# CREATEDB). Build first: `cargo build --release --bin abba -p abba-client
# --example load`. A benchmark, not a test: run it on a machine that is
# otherwise quiet, and compare the lines of one run with each other.
# abba is research software, not a medical device.
set -euo pipefail
pg="${1:?usage: run.sh POSTGRES_URL [SECONDS]}"
secs="${2:-30}"
bin=target/release/abba
load=target/release/examples/load
[ -x "$bin" ] && [ -x "$load" ] || { echo "build first: cargo build --release --bin abba -p abba-client --example load" >&2; exit 2; }
work=$(mktemp -d)
pids=()
trap 'for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; rm -rf "$work"' EXIT

# A fresh database on the server of $pg: the same URL with its path
# replaced by a new name.
fresh_db() {
  local name="abba_load_$1_$$"
  psql "$pg" -qAt -c "CREATE DATABASE $name" >/dev/null
  python3 - "$pg" "$name" <<'PY'
import re, sys
print(re.sub(r"^([a-z]+://[^/?]*)(/[^?]*)?", lambda m: m.group(1) + "/" + sys.argv[2], sys.argv[1], count=1))
PY
}
# Starts a replica on $1; its URL (the port it chose) in $served. (Not
# a $(...) subshell, so that its pid is kept and the replica stopped after
# its line: a replica left running would compete with the next lines.)
serve() {
  local log="$work/serve-$RANDOM.log"
  "$bin" serve --db "$1" --listen 127.0.0.1:0 >"$log" 2>&1 &
  pids+=($!)
  served=""
  for _ in $(seq 100); do
    served=$(grep -o 'http://127\.0\.0\.1:[0-9]*' "$log" | head -1 || true)
    if [ -n "$served" ]; then return; fi
    sleep 0.1
  done
  echo "abba serve did not start: $(cat "$log")" >&2; exit 1
}

line() { # backend replicas clients batch db
  local urls=() args=()
  for _ in $(seq "$2"); do serve "$5"; urls+=("$served"); done
  for u in "${urls[@]}"; do args+=(--url "$u"); done
  local token
  token=$("$bin" token --db "$5" --admin 2>/dev/null)
  local out
  out=$("$load" "${args[@]}" --token "$token" --clients "$3" --batch "$4" --seconds "$secs" | tail -2 | tr '\n' ' ')
  echo "| $1 | $2 | $3 | $4 | $out|"
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  pids=()
  sleep 1
}

echo "$(date -u '+%F %H:%M UTC'), load $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores, $secs s a line"
echo "| backend | replicas | clients | events per request | result |"
echo "|---|---:|---:|---:|---|"
for shape in "50 1" "50 12"; do
  set -- $shape
  line sqlite 1 "$1" "$2" "$work/load-$1-$2.db"
  line postgres 1 "$1" "$2" "$(fresh_db "one_$1_$2")"
  line postgres 2 "$1" "$2" "$(fresh_db "two_$1_$2")"
done
