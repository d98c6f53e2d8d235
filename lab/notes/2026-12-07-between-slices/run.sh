#!/bin/sh
# Side by side on the issue-48 cases (lab note 2026-12-07-between-slices.md): train one binary
# on the cine ring (20 mm kept slices), the lesion (5 and 10 mm) and the nested LV (RT Structure
# Sets every 10 mm), score the held-out slices with the cases' own scorers (ring, lesion: labels
# on the truth's grid; nested: `dynaslice eval heldout`), and measure the field between the
# slices (between.py; ring and lesion). ITK's filter on the same kept slices: the cases' `itk`.
#
#   sh run.sh DYNASLICE OUT TAG SEED [STEPS] [CASES]
#       OUT: the cases' folder (made on first use); TAG names the runs (e.g. base, new);
#       CASES: any of ring lesion5 lesion10 nested (default all four); EXTRA in the environment:
#       more training options (e.g. EXTRA='--lambda-regulariser 1')
set -eu
bin=$1; out=$2; tag=$3; seed=$4; steps=${5:-1000}; cases=${6:-ring lesion5 lesion10 nested}
here=$(cd "$(dirname "$0")" && pwd)
lab=$here/../../cases
mkdir -p "$out"
if [ ! -f "$out/ring/itk.nii.gz" ]; then
  python3 "$lab/cine_ring.py" make "$out/ring" > /dev/null && python3 "$lab/cine_ring.py" itk "$out/ring"
fi
if [ ! -f "$out/les/itk10.nii.gz" ]; then
  python3 "$lab/lesion.py" make "$out/les" > /dev/null
  python3 "$lab/lesion.py" itk "$out/les" 5 && python3 "$lab/lesion.py" itk "$out/les" 10
fi
if [ ! -f "$out/nested/case/kept.seq" ]; then
  mkdir -p "$out/nested" && python3 "$lab/nested_heart.py" "$out/nested/case" > /dev/null
fi
for c in $cases; do
  case $c in
    ring) d=$out/ring; input=$d/kept.nii.gz; truth=$d/truth.nii.gz ;;
    lesion5) d=$out/les; input=$d/kept5.nii.gz; truth=$d/truth.nii.gz ;;
    lesion10) d=$out/les; input=$d/kept10.nii.gz; truth=$d/truth.nii.gz ;;
    nested) d=$out/nested; input=$d/case/kept.seq ;;
  esac
  m=$d/$tag-$c-s$seed
  start=$(date +%s)
  nice -n 10 "$bin" train "$input" -o "$m.dsm" --steps "$steps" --seed "$seed" --threads 2 \
    --force ${EXTRA:-} > "$m.train.log" 2>&1
  echo "$c $tag seed $seed: trained in $(( $(date +%s) - start )) s"
  if [ "$c" = nested ]; then
    RAYON_NUM_THREADS=2 "$bin" eval heldout "$m.dsm" "$d/case/heldout.seq" --holdout-planes 0: \
      > "$m.score.txt" 2>&1
    cat "$m.score.txt"
    continue
  fi
  "$bin" labels "$m.dsm" --like "$truth" -o "$m.nii.gz" --force > /dev/null 2>&1
  case $c in
    ring) python3 "$lab/cine_ring.py" score "$d" "$m.nii.gz" > "$m.score.json"
          python3 "$here/between.py" ring "$d" "$m.dsm" > "$m.between.jsonl" ;;
    lesion5) python3 "$lab/lesion.py" score "$d" 5 "$m.nii.gz" > "$m.score.json"
             python3 "$here/between.py" lesion "$d" 5 "$m.dsm" > "$m.between.jsonl" ;;
    lesion10) python3 "$lab/lesion.py" score "$d" 10 "$m.nii.gz" > "$m.score.json"
              python3 "$here/between.py" lesion "$d" 10 "$m.dsm" > "$m.between.jsonl" ;;
  esac
  cat "$m.score.json"
done
