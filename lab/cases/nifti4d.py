"""A smooth "hidden-style" 4D label NIfTI, like a user's cine MRI segmentation: ten frames of a
beating heart's left-ventricle cavity (an ellipsoid), its myocardium (a shell 7 mm thick
around it) and the right-ventricle cavity (a half-ellipsoid wrapped on its side), on a 2 mm
grid (64×64×40), the radii pulsing ±12 % over one beat. Written by nibabel (RAS, 4D, uint8,
pixdim[4] = 0.08 s); `dynaslice train` reslices it by the paper's protocol, so the trained
model sees planes, not the volume, and is scored against the whole volume at every frame.

    python3 lab/cases/nifti4d.py make DIR             # writes DIR/heart4d.nii.gz
    python3 lab/cases/nifti4d.py score TRUTH PRED     # one JSON line: per class pooled IoU

The score is, per class, the IoU pooled over all frames ("iou"), the worst frame ("iou_min")
and the predicted / true volume ("volume_ratio"), then the mean IoU of the classes.
"""
import json
import os
import sys

import nibabel as nib
import numpy as np

SHAPE = (64, 64, 40)
VOXEL = 2.0
FRAMES = 10
DT = 0.08
NAMES = ["LV", "Myo", "RV"]


def frame(t):
    """Label volume of frame t (0..FRAMES-1)."""
    s = 1.0 + 0.12 * np.cos(2 * np.pi * t / FRAMES)  # end-diastole at t = 0
    idx = np.indices(SHAPE).transpose(1, 2, 3, 0).astype(float)
    p = (idx - (np.array(SHAPE) - 1) / 2) * VOXEL  # mm about the centre
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    lv = np.sqrt((x / (18 * s)) ** 2 + (y / (18 * s)) ** 2 + (z / (28 * s)) ** 2)
    myo = np.sqrt((x / (18 * s + 7)) ** 2 + (y / (18 * s + 7)) ** 2 + (z / (28 * s + 7)) ** 2)
    rv = np.sqrt(((x + 30) / (20 * s)) ** 2 + (y / (26 * s)) ** 2 + (z / (24 * s)) ** 2)
    vol = np.zeros(SHAPE, np.uint8)
    vol[(rv <= 1) & (myo > 1)] = 3
    vol[myo <= 1] = 2
    vol[lv <= 1] = 1
    return vol


def make(d):
    os.makedirs(d, exist_ok=True)
    data = np.stack([frame(t) for t in range(FRAMES)], axis=-1)
    affine = np.diag([VOXEL, VOXEL, VOXEL, 1.0])
    affine[:3, 3] = -(np.array(SHAPE) - 1) / 2 * VOXEL
    img = nib.Nifti1Image(data, affine)
    img.header.set_xyzt_units("mm", "sec")
    img.header["pixdim"][4] = DT
    nib.save(img, os.path.join(d, "heart4d.nii.gz"))
    print(json.dumps({n: int((data == i).sum()) for i, n in enumerate(NAMES, start=1)}))


def score(truth_path, pred_path):
    truth = np.asarray(nib.load(truth_path).dataobj)
    pred = np.asarray(nib.load(pred_path).dataobj)
    if truth.shape != pred.shape:
        sys.exit(f"{pred_path}: shape {pred.shape}, the truth's is {truth.shape}")
    out = {}
    for i, n in enumerate(NAMES, start=1):
        t, p = truth == i, pred == i
        per = [
            (t[..., f] & p[..., f]).sum() / max((t[..., f] | p[..., f]).sum(), 1)
            for f in range(t.shape[-1])
        ]
        out[n] = {
            "iou": round(float((t & p).sum() / max((t | p).sum(), 1)), 4),
            "iou_min": round(float(min(per)), 4),
            "volume_ratio": round(float(p.sum() / max(t.sum(), 1)), 3),
        }
    out["mean_iou"] = round(float(np.mean([out[n]["iou"] for n in NAMES])), 4)
    print(json.dumps(out))


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "make":
        make(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "score":
        score(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
