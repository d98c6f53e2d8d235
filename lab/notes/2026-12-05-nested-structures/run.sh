#!/bin/sh
# Nested structures (issue 36): an LV with the endocardium drawn inside the epicardium, two
# phases at trigger times in ms, RT Structure Sets by pydicom (lab/cases/nested_heart.py).
# Trains on every other plane (10 mm) three ways: nested (default --nesting auto), as drawn
# (--nesting off) and the endocardium alone; scores the held-out planes (the other 5 mm planes)
# and compares measure's volumes with Simpson's rule over all contours (5 mm).
#
#   sh lab/notes/2026-12-05-nested-structures/run.sh OUT_DIR [STEPS]
set -eu
out=$1
steps=${2:-1000}
bin=${DYNASLICE:-target/release/dynaslice}
mkdir -p "$out"
python3 lab/cases/nested_heart.py "$out/case" > "$out/simpson.json"
for m in nested:kept.seq: asdrawn:kept.seq:--nesting=off endo:kept_endo.seq:; do
  name=${m%%:*}; rest=${m#*:}; input=${rest%%:*}; extra=${rest#*:}
  start=$(date +%s)
  # shellcheck disable=SC2086
  nice -n 5 "$bin" train "$out/case/$input" -o "$out/$name.dsm" --steps "$steps" --seed 1 \
    --threads 1 --force $extra 2> "$out/$name.train.log"
  echo "$name: trained in $(( $(date +%s) - start )) s"
done
for m in nested:heldout.seq asdrawn:heldout.seq endo:heldout_endo.seq; do
  name=${m%%:*}; input=${m#*:}
  echo "== held-out planes, $name"
  RAYON_NUM_THREADS=1 "$bin" eval heldout "$out/$name.dsm" "$out/case/$input" \
    --holdout-planes 0: 2> "$out/$name.heldout.log"
done
for name in nested asdrawn; do
  echo "== measure $name"
  "$bin" measure "$out/$name.dsm" --times 287.7:709.7:2 --json > "$out/$name.measure.json" \
    2> "$out/$name.measure.log"
  python3 - "$out/simpson.json" "$out/$name.measure.json" <<'PY'
import json, sys
simpson = json.load(open(sys.argv[1]))
m = json.load(open(sys.argv[2]))
for c in m["classes"]:
    for t, v in zip(m["times"], c["volume_ml"]):
        phase = "ED" if abs(t - 287.7) < 1 else "ES"
        ref = simpson[f"{phase} {c['name']}"]["simpson_mL"]
        print(f"{phase} {c['name']}: measure {v:.2f} mL, Simpson {ref:.2f} mL, "
              f"{100 * (v - ref) / ref:+.2f} %")
PY
done
"$bin" info "$out/nested.dsm" | grep -i nesting || true
