#!/usr/bin/env bash
# ABBA's gains against run-to-run's frontier (issue 26 item 2): the default
# trial's S1 and S2 (abba, standard, r2r; default cohort and seed) with the
# θ0 of the basal and carb-ratio agents (and the CIR switch rule) changed,
# one run per line of VARIANTS, then the arms table of each report.
# Usage: benches/diagnosis/gains.sh ABBA_BINARY OUT_DIR
set -euo pipefail
abba=$1
out=$2
mkdir -p "$out"
"$abba" trial --print-config >"$out/base.json"
# name | θ0_br (hyper, hypo) | θ0_cir (hyper, hypo) | switch rule
VARIANTS="
default|0.15,-0.20|-0.15,0.20|true
switch-off|0.15,-0.20|-0.15,0.20|false
both-0.30|0.30,-0.20|-0.30,0.20|true
both-0.30-hypo-0.40|0.30,-0.40|-0.30,0.40|true
both-0.60|0.60,-0.20|-0.60,0.20|true
basal-0.60|0.60,-0.20|-0.15,0.20|true
basal-0.45-hypo-0.40|0.45,-0.40|-0.15,0.40|true
basal-0.45-hypo-0.60|0.45,-0.60|-0.15,0.40|true
basal-0.60-hypo-0.80|0.60,-0.80|-0.15,0.40|true
cir-0.60-switch-off|0.15,-0.20|-0.60,0.20|false
"
for line in $VARIANTS; do
  IFS='|' read -r name br cir switch <<<"$line"
  python3 - "$out/base.json" "$out/$name.json" "$br" "$cir" "$switch" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))
c["abba"]["te"]["theta0_br"] = [float(x) for x in sys.argv[3].split(",")]
c["abba"]["te"]["theta0_cir"] = [float(x) for x in sys.argv[4].split(",")]
c["abba"]["update"]["switch_rule"] = sys.argv[5] == "true"
json.dump(c, open(sys.argv[2], "w"))
PY
  rm -rf "$out/$name"
  "$abba" trial --config "$out/$name.json" --scenarios S1,S2 --quiet --out "$out/$name"
  echo "## $name (θ0_br $br, θ0_cir $cir, switch rule $switch)"
  python3 "$(dirname "$0")/../autotune_arm/arms_table.py" "$out/$name" | head -6
done
