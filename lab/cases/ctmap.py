"""Scores a model of a static label map (the shared TotalSegmentator CT,
../shared/data/nifti/example_seg.nii.gz) by volume and by support: a class must not grow
beyond its labelled volume, nor leave the imaged box.

    dynaslice train SEG --labels 1,2,3 --steps 300 -o m.dsm
    dynaslice labels m.dsm -o pred.nii.gz --spacing 2       # the model's whole domain
    python3 lab/cases/ctmap.py SEG pred.nii.gz 1,2,3

`pred.nii.gz` holds the Eq. 11 labels over the model's domain (the data's box plus 10 %, larger
than the image), class k of the model as value k, so structure grown past the image is seen.
Prints one JSON line: per label value, the labelled volume (mm³), the predicted one over the
whole domain and inside the imaged box, their ratio to the labelled volume, and how far the
predicted voxels reach past the imaged box (mm; 0 inside), and the volume farther than 10 mm
past it.
"""
import json
import sys

import nibabel as nib
import numpy as np


def world_box(img):
    """The image's box in world (RAS) mm: its voxels' corners."""
    shape = np.array(img.shape[:3])
    corners = np.array([[i, j, k] for i in (-0.5, shape[0] - 0.5) for j in (-0.5, shape[1] - 0.5)
                        for k in (-0.5, shape[2] - 0.5)])
    w = nib.affines.apply_affine(img.affine, corners)
    return w.min(0), w.max(0)


def main(seg_path, pred_path, labels):
    seg = nib.load(seg_path)
    pred = nib.load(pred_path)
    s = np.asarray(seg.dataobj)
    p = np.asarray(pred.dataobj)
    if p.ndim == 4:
        p = p[..., 0]
    v_seg = abs(np.linalg.det(seg.affine[:3, :3]))
    v_pred = abs(np.linalg.det(pred.affine[:3, :3]))
    lo, hi = world_box(seg)
    out = {"imaged_box_mm": [lo.round(1).tolist(), hi.round(1).tolist()]}
    for k, value in enumerate(labels, start=1):
        idx = np.argwhere(p == k)
        w = nib.affines.apply_affine(pred.affine, idx) if len(idx) else np.zeros((0, 3))
        past = np.linalg.norm(np.maximum(0, np.maximum(lo - w, w - hi)), axis=1)
        labelled = float((s == value).sum() * v_seg)
        predicted = float(len(idx) * v_pred)
        inside = float((past == 0).sum() * v_pred)
        out[str(value)] = {
            "labelled_mm3": round(labelled),
            "predicted_mm3": round(predicted),
            "ratio": round(predicted / labelled, 3) if labelled else None,
            "ratio_in_box": round(inside / labelled, 3) if labelled else None,
            "reach_past_box_mm": round(float(past.max()), 1) if len(past) else 0.0,
            "mm3_past_10mm": round(float((past > 10).sum() * v_pred)),
        }
    print(json.dumps(out))


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], [int(v) for v in sys.argv[3].split(",")])
