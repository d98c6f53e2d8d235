"""A kidney-tumour-CT-like label map (issue 36, "a small lesion fitted worse from denser
slices"): both kidneys (label 1, ellipsoids about 110 × 60 × 50 mm, 100 mm apart, tilted as
kidneys are) and a tumour (label 2, a ball, default 20 mm across) inside the right kidney,
labelled as KiTS labels them (disjoint: the kidney label stops at the tumour), on 1.25 mm
pixels and 2.5 mm axial slices over a 250 × 200 mm field of view. Axial slices are kept every
5 mm or every 10 mm as the training input; the model and ITK's morphological contour
interpolation (on the same kept slices) are scored by 3D Dice against every slice.

    python3 lab/cases/lesion.py make DIR [--radius MM] [--fov MM] [--length MM]
        # DIR/truth.nii.gz, DIR/kept5.nii.gz, DIR/kept10.nii.gz; --fov: the in-plane field of
        # view (a CT's is 350-500 mm), --length: the scanned length (default 250 / 160 mm)
    python3 lab/cases/lesion.py itk DIR GAP              # DIR/itk{GAP}.nii.gz on the truth's grid
    python3 lab/cases/lesion.py score DIR GAP PRED       # one JSON line
    # the model:
    dynaslice train DIR/kept5.nii.gz --steps 1000 --seed 1 --threads 1 -o DIR/m5.dsm
    dynaslice labels DIR/m5.dsm --like DIR/truth.nii.gz -o DIR/pred5.nii.gz

The score: per structure the 3D Dice over every slice ("dice"), on the kept slices only
("kept_dice": does the model reproduce its own input) and on the held-out slices
("held_dice"), and the predicted / true volume.
"""
import json
import os
import sys

import nibabel as nib
import numpy as np

PIXEL = 1.25  # mm in plane
SLICE = 2.5  # mm, the truth's slice spacing
SHAPE = [200, 160, 64]  # 250 × 200 × 160 mm; `--fov` and `--length` make it a whole abdomen's
NAMES = {1: "kidney", 2: "tumour"}


def volume(radius):
    NX, NY, NZ = SHAPE
    i, j, k = np.indices((NX, NY, NZ)).astype(float)
    x = (i - (NX - 1) / 2) * PIXEL
    y = (j - (NY - 1) / 2) * PIXEL
    z = (k - (NZ - 1) / 2) * SLICE
    vol = np.zeros((NX, NY, NZ), np.uint8)
    tumour = None
    for side in (-1.0, 1.0):
        cx, cy, cz = side * 50.0, 15.0, side * 6.0
        # tilted 20° about y (the poles lean medially) and 15° about z
        a, b = np.radians(20.0) * side, np.radians(15.0) * side
        px, py, pz = x - cx, y - cy, z - cz
        u = np.cos(a) * px - np.sin(a) * pz
        w = np.sin(a) * px + np.cos(a) * pz
        u, v = np.cos(b) * u - np.sin(b) * py, np.sin(b) * u + np.cos(b) * py
        kid = (u / 30.0) ** 2 + (v / 25.0) ** 2 + (w / 55.0) ** 2 <= 1
        vol[kid] = 1
        if side < 0:
            # the tumour: inside the right kidney's lower pole, off its axis
            tx, ty, tz = cx + 4.0, cy - 3.0, cz + 22.0
            tumour = (x - tx) ** 2 + (y - ty) ** 2 + (z - tz) ** 2 <= radius**2
            if (tumour & ~kid).any():
                sys.exit(f"a tumour of radius {radius} mm leaves the kidney: pick a smaller one")
    vol[tumour] = 2
    return vol


def affine(step):
    NX, NY, NZ = SHAPE
    a = np.diag([PIXEL, PIXEL, SLICE * step, 1.0])
    a[:3, 3] = [-(NX - 1) / 2 * PIXEL, -(NY - 1) / 2 * PIXEL, -(NZ - 1) / 2 * SLICE]
    return a


def kept(gap):
    step = int(round(gap / SLICE))
    return list(range(1, SHAPE[2], step)), step


def make(d, radius):
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "case.json"), "w") as f:
        json.dump({"radius": radius, "shape": SHAPE}, f)
    vol = volume(radius)
    nib.save(nib.Nifti1Image(vol, affine(1)), os.path.join(d, "truth.nii.gz"))
    for gap in (5, 10):
        ks, step = kept(gap)
        aff = affine(step)
        aff[2, 3] += ks[0] * SLICE  # the first kept slice's position
        sub = np.ascontiguousarray(vol[:, :, ks])
        nib.save(nib.Nifti1Image(sub, aff), os.path.join(d, f"kept{gap}.nii.gz"))
    print(json.dumps({n: int((vol == lab).sum()) for lab, n in NAMES.items()}))


def load_shape(d):
    with open(os.path.join(d, "case.json")) as f:
        SHAPE[:] = json.load(f)["shape"]


def itk(d, gap):
    import itk as itk_

    load_shape(d)
    truth = np.asarray(nib.load(os.path.join(d, "truth.nii.gz")).dataobj)
    ks, _ = kept(gap)
    sparse = np.zeros_like(truth)
    sparse[:, :, ks] = truth[:, :, ks]
    img = itk_.GetImageFromArray(np.ascontiguousarray(sparse.transpose(2, 1, 0)))
    img.SetSpacing([PIXEL, PIXEL, SLICE])
    out = itk_.GetArrayFromImage(itk_.morphological_contour_interpolator(img, axis=2))
    out = np.ascontiguousarray(out.transpose(2, 1, 0))
    nib.save(nib.Nifti1Image(out, affine(1)), os.path.join(d, f"itk{gap}.nii.gz"))


def dice(a, b):
    s = a.sum() + b.sum()
    return 1.0 if s == 0 else float(2 * (a & b).sum() / s)


def score(d, gap, pred_path):
    load_shape(d)
    truth = np.asarray(nib.load(os.path.join(d, "truth.nii.gz")).dataobj)
    pred = np.asarray(nib.load(pred_path).dataobj)
    if pred.ndim == 4:
        pred = pred[..., 0]
    if truth.shape != pred.shape:
        sys.exit(f"{pred_path}: shape {pred.shape}, the truth's is {truth.shape}")
    ks, _ = kept(gap)
    held = [z for z in range(SHAPE[2]) if z not in set(ks)]
    out = {"gap_mm": gap}
    for lab, n in NAMES.items():
        T, P = truth == lab, pred == lab
        out[n] = {
            "dice": round(dice(T, P), 4),
            "kept_dice": round(dice(T[:, :, ks], P[:, :, ks]), 4),
            "held_dice": round(dice(T[:, :, held], P[:, :, held]), 4),
            "volume_ratio": round(float(P.sum() / max(T.sum(), 1)), 3),
        }
    print(json.dumps(out))


if __name__ == "__main__":
    a = sys.argv[1:]
    if len(a) >= 2 and a[0] == "make":
        opt = dict(zip(a[2::2], a[3::2]))
        if "--fov" in opt:
            SHAPE[0] = SHAPE[1] = int(round(float(opt["--fov"]) / PIXEL))
        if "--length" in opt:
            SHAPE[2] = int(round(float(opt["--length"]) / SLICE))
        make(a[1], float(opt.get("--radius", 10.0)))
    elif len(a) == 3 and a[0] == "itk":
        itk(a[1], int(a[2]))
    elif len(a) == 4 and a[0] == "score":
        score(a[1], int(a[2]), a[3])
    else:
        sys.exit(__doc__)
