"""Scores label volumes of the 4D RTSTRUCT case (lab/cases/rtstruct4d.py) against its truth, and
makes the users' bar: 3D Slicer's "fill between slices" (ITK's morphological contour
interpolation, itk-morphologicalcontourinterpolation) on each contoured phase, the nearest
contoured phase for the others.

    python3 lab/cases/score4d.py CASE_DIR --itk            # the ITK baseline's scores
    python3 lab/cases/score4d.py CASE_DIR PRED.nii.gz      # a prediction's scores

The contoured phases and the truth's frames (as phases, fractional with `rtstruct4d.py --all`)
come from CASE_DIR/case.json. A prediction may hold the first frames only: `dynaslice labels`
answers within the model's time range, which ends at the last contoured phase; the frames the
prediction has are scored.

Prints one JSON line per source: per class the IoU pooled over all frames ("iou"), over the
frames at contoured phases ("iou_contoured"), the worst frame ("iou_min"), the predicted / true
volume ("volume_ratio"), its least and greatest value over the frames ("volume_ratio_range"),
the superior-inferior travel of the class's centroid over the frames, predicted and true, mm
("si_travel_mm"), and the connected components (26-connected, per frame) farther than 5 mm from
every contour of their class on the bracketing contoured phases ("far_components", with their
voxel counts and distances).
"""
import json
import os
import sys

import nibabel as nib
import numpy as np
from scipy.spatial import cKDTree
from skimage.draw import polygon as fill_polygon
from skimage.measure import label as components

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rtstruct4d as case  # noqa: E402

FAR_MM = 5.0


def to_index(points):
    """RAS mm → fractional voxel indices (x, y, z)."""
    p = np.asarray(points, float)
    return (p - np.asarray(case.ORIGIN)) / case.VOXEL


def rasterise(phase):
    """The phase's contours filled on their slices (even-odd per class), 0 elsewhere."""
    vol = np.zeros(case.SHAPE, np.uint8)
    for value, name in enumerate(case.NAMES, start=1):
        by_slice = {}
        for poly in case.contours(phase)[name]:
            idx = to_index(poly)
            k = int(round(idx[0, 2]))
            rr, cc = fill_polygon(idx[:, 0], idx[:, 1], case.SHAPE[:2])
            m = by_slice.setdefault(k, np.zeros(case.SHAPE[:2], bool))
            m[rr, cc] ^= True
        for k, m in by_slice.items():
            vol[:, :, k][m] = value
    return vol


def load_case(d):
    """The contoured phases and the truth's frames (as phases) of the case in `d`."""
    with open(os.path.join(d, "case.json")) as f:
        c = json.load(f)
    return c["contoured_phases"], c.get("truth_phases", list(range(case.PHASES)))


CONTOURED, TRUTH_PHASES = case.CONTOURED, list(range(case.PHASES))


def itk_baseline():
    import itk

    filled = {}
    for p in CONTOURED:
        arr = np.ascontiguousarray(rasterise(p).transpose(2, 1, 0))  # z, y, x for ITK
        img = itk.GetImageFromArray(arr)
        out = itk.morphological_contour_interpolator(img, axis=2)
        filled[p] = itk.GetArrayFromImage(out).transpose(2, 1, 0)
    nearest = lambda q: min(CONTOURED, key=lambda p: (abs(p - q), p))  # noqa: E731
    return np.stack([filled[nearest(q)] for q in TRUTH_PHASES], axis=-1)


def bracketing(q):
    """The contoured phases nearest below and above phase q (one if q is contoured)."""
    lo = [p for p in CONTOURED if p <= q]
    hi = [p for p in CONTOURED if p >= q]
    return sorted({x for x in (lo[-1] if lo else None, hi[0] if hi else None) if x is not None})


def score(pred, truth):
    out = {}
    for value, name in enumerate(case.NAMES, start=1):
        P, T = pred == value, truth == value
        inter = (P & T).sum(axis=(0, 1, 2))
        union = (P | T).sum(axis=(0, 1, 2))
        frames = range(P.shape[-1])
        cont = [f for f in frames if TRUTH_PHASES[f] in CONTOURED]
        far = []
        for f in frames:
            q = TRUTH_PHASES[f]
            pts = np.concatenate([to_index(poly) for p in bracketing(q)
                                  for poly in case.contours(p)[name]])
            tree = cKDTree(pts)
            lab, n = components(P[..., f], return_num=True, connectivity=3)
            for c in range(1, n + 1):
                vox = np.argwhere(lab == c)
                # distance (mm) from the component's nearest voxel to the nearest contour point
                d = tree.query(vox)[0].min() * case.VOXEL
                if d > FAR_MM:
                    far.append({"phase": round(q, 2), "voxels": int(len(vox)),
                                "mm": round(float(d), 1)})
        ratio = P.sum(axis=(0, 1, 2)) / np.maximum(T.sum(axis=(0, 1, 2)), 1)
        z = np.arange(P.shape[2])[None, None, :, None] * case.VOXEL
        centroid_z = [(M * z).sum(axis=(0, 1, 2)) / np.maximum(M.sum(axis=(0, 1, 2)), 1)
                      for M in (P, T)]
        travel = [float(np.ptp(c)) for c in centroid_z]
        out[name] = {
            "iou": round(float(inter.sum() / max(union.sum(), 1)), 4),
            "iou_contoured": round(float(inter[cont].sum() / max(union[cont].sum(), 1)), 4),
            "iou_min": round(float((inter / np.maximum(union, 1)).min()), 4),
            "volume_ratio": round(float(P.sum() / max(T.sum(), 1)), 3),
            "volume_ratio_range": [round(float(r), 3) for r in (ratio.min(), ratio.max())],
            "si_travel_mm": [round(travel[0], 2), round(travel[1], 2)],
            "far_components": far,
        }
    return out


def main():
    global CONTOURED, TRUTH_PHASES
    d = sys.argv[1]
    CONTOURED, TRUTH_PHASES = load_case(d)
    truth = np.asarray(nib.load(os.path.join(d, "truth.nii.gz")).dataobj)
    if sys.argv[2] == "--itk":
        src, pred = "itk-morphological-contour-interpolation", itk_baseline()
    else:
        src, img = sys.argv[2], nib.load(sys.argv[2])
        pred = np.asarray(img.dataobj)
        if pred.shape[:3] != truth.shape[:3] or pred.shape[-1] > truth.shape[-1]:
            sys.exit(f"{src}: shape {pred.shape}, the truth's is {truth.shape}")
        # `dynaslice labels` stays within the model's time range, which ends at the last
        # contoured phase: score the phases the prediction has (made with --like truth9.nii.gz)
        truth = truth[..., : pred.shape[-1]]
    print(json.dumps({"source": src, "phases": int(truth.shape[-1]),
                      "classes": score(pred, truth)}))


if __name__ == "__main__":
    main()
