"""Compact table of between.py's lines: per phase and class, on each held-out slice the model's
mean f over the truth's inside against the truth's mean 3D distance there (mm), the share of
the inside the channel loses, and its Dice; then the same mean on the kept slices.

    python3 table.py RUN.between.jsonl
"""
import json
import sys

for line in open(sys.argv[1]):
    r = json.loads(line)
    held = [
        f"{z}: {c['f_in']:+.1f}/{c['sdf_in']:+.1f} lost {c['lost']:.2f} dice {c['dice']:.2f}"
        for z, c in r["held"].items()
        if "f_in" in c
    ]
    kept = [f"{z}: {c['f_in']:+.1f}/{c['sdf_in']:+.1f}" for z, c in r["kept"].items()]
    print(f"{r['phase']} {r['cls']}: held " + "; ".join(held) + " | kept " + "; ".join(kept))
