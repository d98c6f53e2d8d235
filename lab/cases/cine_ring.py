"""A short-axis cine-like 4D label map (issue 36, "no structure lost between slices that show
it"): the left-ventricle cavity, its myocardium (a ring 6–10 mm thick) and the right-ventricle
crescent on the septal side, at end-diastole and end-systole, on 1.5 × 1.5 mm pixels and
10 mm short-axis slices, labelled as cine segmentations are (disjoint: 1 RV, 2 myocardium,
3 LV cavity, as ACDC/M&Ms). Every other short-axis slice is kept as the training input; the
held-out slices are scored per structure (Dice) for the model and for ITK's morphological
contour interpolation run on the same kept slices.

    python3 lab/cases/cine_ring.py make DIR [--wall-ed MM] [--wall-es MM]
        # DIR/truth.nii.gz (all slices, 2 frames), DIR/kept.nii.gz (every other slice)
    python3 lab/cases/cine_ring.py itk DIR          # DIR/itk.nii.gz, on the truth's grid
    python3 lab/cases/cine_ring.py score DIR PRED   # one JSON line
    # the model:
    dynaslice train DIR/kept.nii.gz --steps 1000 --seed 1 --threads 1 -o DIR/m.dsm
    dynaslice labels DIR/m.dsm --like DIR/truth.nii.gz -o DIR/pred.nii.gz

The score, per phase and structure: Dice on each held-out slice, the worst held-out "interior"
slice (one whose two kept neighbours both show the structure), the number of interior
held-out slices where the structure is lost (Dice < 0.5), the pooled held-out Dice, and the
pooled Dice on the kept slices (does the model reproduce its own input).
"""
import json
import os
import sys

import nibabel as nib
import numpy as np

PIXEL = 1.5  # mm, in plane
SLICE = 10.0  # mm, short-axis slice spacing (cine: 8 mm slices + 2 mm gap)
NX, NY, NZ = 128, 128, 12
NAMES = {1: "RV", 2: "Myo", 3: "LV"}
DT = 0.3  # s between the two frames (ED at 0, ES at 0.3)


def phase(es, wall_ed=8.0, wall_es=10.0):
    """Label volume of one phase: ED (es=False) or ES (es=True)."""
    i, j, k = np.indices((NX, NY, NZ)).astype(float)
    x = (i - (NX - 1) / 2) * PIXEL
    y = (j - (NY - 1) / 2) * PIXEL
    z = k * SLICE + SLICE / 2  # slice centres; base near k = 1, apex near k = 10
    # LV cavity: half a prolate ellipsoid, base plane at z_base, apex towards +z.
    z_base = 12.0 if not es else 18.0  # the base descends towards the apex in systole
    cav_r, cav_l = (26.0, 78.0) if not es else (17.0, 62.0)
    wall = wall_es if es else wall_ed
    dz = np.maximum(z - z_base, 0.0)
    above = z < z_base
    r = np.hypot(x, y)
    cav = (r / cav_r) ** 2 + (dz / cav_l) ** 2 <= 1
    epi = (r / (cav_r + wall)) ** 2 + (dz / (cav_l + wall)) ** 2 <= 1
    # RV: a crescent wrapped on the septal side (-x), shorter than the LV.
    rv_cx = -(cav_r + wall) * 0.75
    rv_a, rv_b, rv_l = (cav_r + wall + 14.0, cav_r + wall + 22.0, cav_l * 0.8)
    if es:
        rv_a -= 6.0
        rv_b -= 6.0
    rv = ((x - rv_cx) / rv_a) ** 2 + (y / rv_b) ** 2 + (dz / rv_l) ** 2 <= 1
    rv &= ~epi & (x < 4.0)
    vol = np.zeros((NX, NY, NZ), np.uint8)
    vol[rv & ~above] = 1
    vol[epi & ~cav & ~above] = 2
    vol[cav & ~above] = 3
    return vol


def affine(step, first=0):
    """Voxel to world (mm); `first` is the truth's slice index of the image's slice 0."""
    a = np.diag([PIXEL, PIXEL, SLICE * step, 1.0])
    a[:3, 3] = [-(NX - 1) / 2 * PIXEL, -(NY - 1) / 2 * PIXEL, first * SLICE]
    return a


def save(data, step, path, first=0):
    img = nib.Nifti1Image(data, affine(step, first))
    img.header.set_xyzt_units("mm", "sec")
    img.header["pixdim"][4] = DT
    nib.save(img, path)


def kept_slices():
    return list(range(1, NZ, 2))  # the basal slice kept, as a user would


def make(d, wall_ed, wall_es):
    os.makedirs(d, exist_ok=True)
    truth = np.stack([phase(False, wall_ed, wall_es), phase(True, wall_ed, wall_es)], axis=-1)
    save(truth, 1, os.path.join(d, "truth.nii.gz"))
    keep = kept_slices()
    sub = np.ascontiguousarray(truth[:, :, keep, :])
    save(sub, 2, os.path.join(d, "kept.nii.gz"), first=keep[0])
    with open(os.path.join(d, "case.json"), "w") as f:
        json.dump({"wall_ed": wall_ed, "wall_es": wall_es, "kept": kept_slices()}, f)
    counts = {
        n: [[int((truth[:, :, z, t] == lab).sum()) for z in range(NZ)] for t in range(2)]
        for lab, n in NAMES.items()
    }
    print(json.dumps({"pixels_per_slice": counts}))


def itk(d):
    import itk as itk_

    truth = np.asarray(nib.load(os.path.join(d, "truth.nii.gz")).dataobj)
    out = np.zeros_like(truth)
    keep = kept_slices()
    for t in range(truth.shape[-1]):
        sparse = np.zeros(truth.shape[:3], np.uint8)
        sparse[:, :, keep] = truth[:, :, keep, t]
        img = itk_.GetImageFromArray(np.ascontiguousarray(sparse.transpose(2, 1, 0)))
        img.SetSpacing([PIXEL, PIXEL, SLICE])
        filled = itk_.morphological_contour_interpolator(img, axis=2)
        out[..., t] = itk_.GetArrayFromImage(filled).transpose(2, 1, 0)
    save(out, 1, os.path.join(d, "itk.nii.gz"))


def dice(a, b):
    s = a.sum() + b.sum()
    return 1.0 if s == 0 else float(2 * (a & b).sum() / s)


def score(d, pred_path):
    truth = np.asarray(nib.load(os.path.join(d, "truth.nii.gz")).dataobj)
    pred = np.asarray(nib.load(pred_path).dataobj)
    if truth.shape != pred.shape:
        sys.exit(f"{pred_path}: shape {pred.shape}, the truth's is {truth.shape}")
    keep = set(kept_slices())
    held = [z for z in range(NZ) if z not in keep]
    out = {}
    for t, ph in enumerate(["ED", "ES"]):
        for lab, n in NAMES.items():
            T, P = truth[..., t] == lab, pred[..., t] == lab
            per = {}
            interior = []
            for z in held:
                if T[:, :, z].sum() == 0 and P[:, :, z].sum() == 0:
                    continue
                per[z] = round(dice(T[:, :, z], P[:, :, z]), 3)
                if 0 < z < NZ - 1 and T[:, :, z - 1].any() and T[:, :, z + 1].any():
                    interior.append(z)
            hz, kz = sorted(held), sorted(keep)
            out[f"{ph}/{n}"] = {
                "held_out": per,
                "interior_worst": min((per[z] for z in interior), default=None),
                "interior_lost": sum(per[z] < 0.5 for z in interior),
                "held_out_dice": round(dice(T[:, :, hz], P[:, :, hz]), 3),
                "kept_dice": round(dice(T[:, :, kz], P[:, :, kz]), 3),
            }
    print(json.dumps(out))


if __name__ == "__main__":
    a = sys.argv[1:]
    if len(a) >= 2 and a[0] == "make":
        opt = dict(zip(a[2::2], a[3::2]))
        make(a[1], float(opt.get("--wall-ed", 8.0)), float(opt.get("--wall-es", 10.0)))
    elif len(a) == 2 and a[0] == "itk":
        itk(a[1])
    elif len(a) == 3 and a[0] == "score":
        score(a[1], a[2])
    else:
        sys.exit(__doc__)
