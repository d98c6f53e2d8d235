"""A thin vessel that sways, as a 4D label NIfTI: one tube of radius 9 mm with rounded ends,
110 mm long along z, whose centre line bows sideways (x) by up to ±35 mm over one cycle:
x(z, t) = 35 sin(2π t/T) cos(π z/110) mm, straight at the start, the middle and the end of the
cycle. 37 frames on a 2 mm grid (64×48×72), pixdim[4] = 0.1 s, written by nibabel (RAS, uint8).
`dynaslice train` reslices it by the paper's protocol; train on every 4th frame
(`--frames 0:37:4`, 10 frames) and score every one of the 37.

    python3 lab/cases/tube4d.py make DIR             # writes DIR/tube4d.nii.gz
    python3 lab/cases/tube4d.py score TRUTH PRED     # one JSON line
    python3 lab/cases/tube4d.py bound                # what interpolating in time can reach

`bound` scores two predictions made from the *true* volumes of the trained frames, no network:
the true signed distance interpolated in time at every voxel (linear, and a cubic spline through
all ten trained frames), and the true shape carried by its motion (the sway amplitude, known at
the trained frames, spline-interpolated). Any model that represents the tube by its signed
distance as a smooth function of time at each point (Eq. 1, band-limited in t by Eq. 4) is
bounded by the first kind; a shape carried by a displacement field reaches the second.

The score: IoU pooled over all frames ("iou"), over the trained frames ("iou_trained"), the
worst frame ("iou_min", and which), the predicted / true volume ("volume_ratio") and its least
and greatest value over the frames ("volume_ratio_range").
"""
import json
import os
import sys

import nibabel as nib
import numpy as np
from scipy.spatial import cKDTree

SHAPE = (64, 48, 72)
VOXEL = 2.0
FRAMES = 37
DT = 0.1
RADIUS = 9.0
HALF_LENGTH = 55.0
SWAY = 35.0
TRAIN_EVERY = 4


def centre_line(t):
    """Points 0.25 mm apart on the centre line at frame t (0..FRAMES-1), mm about the centre."""
    z = np.arange(-HALF_LENGTH, HALF_LENGTH + 1e-9, 0.25)
    x = SWAY * np.sin(2 * np.pi * t / (FRAMES - 1)) * np.cos(np.pi * z / (2 * HALF_LENGTH))
    return np.stack([x, np.zeros_like(z), z], axis=1)


def grid():
    """Voxel centres, mm about the volume's centre, as an (N, 3) array."""
    idx = np.indices(SHAPE).reshape(3, -1).T.astype(float)
    return (idx - (np.array(SHAPE) - 1) / 2) * VOXEL


def frame(t):
    """Label volume of frame t: 1 within RADIUS of the centre line (a swept ball: rounded
    ends)."""
    d, _ = cKDTree(centre_line(t)).query(grid(), distance_upper_bound=RADIUS + 1)
    return (d <= RADIUS).reshape(SHAPE).astype(np.uint8)


def make(d):
    os.makedirs(d, exist_ok=True)
    data = np.stack([frame(t) for t in range(FRAMES)], axis=-1)
    affine = np.diag([VOXEL, VOXEL, VOXEL, 1.0])
    affine[:3, 3] = -(np.array(SHAPE) - 1) / 2 * VOXEL
    img = nib.Nifti1Image(data, affine)
    img.header.set_xyzt_units("mm", "sec")
    img.header["pixdim"][4] = DT
    nib.save(img, os.path.join(d, "tube4d.nii.gz"))
    print(json.dumps({"voxels_per_frame": data.sum(axis=(0, 1, 2)).tolist()}))


def score(truth_path, pred_path):
    truth = np.asarray(nib.load(truth_path).dataobj) == 1
    pred = np.asarray(nib.load(pred_path).dataobj) == 1
    if truth.shape != pred.shape:
        sys.exit(f"{pred_path}: shape {pred.shape}, the truth's is {truth.shape}")
    inter = (truth & pred).sum(axis=(0, 1, 2))
    union = (truth | pred).sum(axis=(0, 1, 2))
    per = inter / np.maximum(union, 1)
    trained = list(range(0, FRAMES, TRAIN_EVERY))
    ratio = pred.sum(axis=(0, 1, 2)) / np.maximum(truth.sum(axis=(0, 1, 2)), 1)
    print(json.dumps({
        "iou": round(float(inter.sum() / max(union.sum(), 1)), 4),
        "iou_trained": round(float(inter[trained].sum() / max(union[trained].sum(), 1)), 4),
        "iou_min": round(float(per.min()), 4),
        "iou_min_frame": int(per.argmin()),
        "volume_ratio": round(float(pred.sum() / max(truth.sum(), 1)), 3),
        "volume_ratio_range": [round(float(ratio.min()), 3), round(float(ratio.max()), 3)],
        "iou_per_frame": [round(float(v), 3) for v in per],
    }))


def bound():
    from scipy.interpolate import CubicSpline
    from scipy.ndimage import distance_transform_edt as edt

    truth = [frame(t).astype(bool) for t in range(FRAMES)]
    trained = list(range(0, FRAMES, TRAIN_EVERY))
    sdf = np.stack([(edt(~truth[t]) - edt(truth[t])) * VOXEL for t in trained])
    spline = CubicSpline(trained, sdf, axis=0)
    amplitude = CubicSpline(trained, [SWAY * np.sin(2 * np.pi * t / (FRAMES - 1)) for t in trained])

    def carried(a):
        line = centre_line(0)
        line[:, 0] = a * np.cos(np.pi * line[:, 2] / (2 * HALF_LENGTH))
        d, _ = cKDTree(line).query(grid(), distance_upper_bound=RADIUS + 1)
        return (d <= RADIUS).reshape(SHAPE)

    def linear(t):
        a = min(t // TRAIN_EVERY, len(trained) - 2)
        s = (t - trained[a]) / TRAIN_EVERY
        return (1 - s) * sdf[a] + s * sdf[a + 1] < 0

    kinds = {
        "sdf_linear": linear,
        "sdf_spline": lambda t: spline(t) < 0,
        "shape_carried": lambda t: carried(float(amplitude(t))),
    }
    out = {}
    for name, predict in kinds.items():
        inter = np.zeros(FRAMES)
        union = np.zeros(FRAMES)
        for t in range(FRAMES):
            p = predict(t)
            inter[t] = (p & truth[t]).sum()
            union[t] = (p | truth[t]).sum()
        per = inter / union
        out[name] = {"iou": round(float(inter.sum() / union.sum()), 3),
                     "iou_min": round(float(per.min()), 3), "iou_min_frame": int(per.argmin())}
    print(json.dumps(out))


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "make":
        make(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "score":
        score(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 2 and sys.argv[1] == "bound":
        bound()
    else:
        sys.exit(__doc__)
