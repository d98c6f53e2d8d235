"""Reads `dynaslice rtstruct` output back with pydicom and compares, per class and time, the
contours' regions (even-odd, rasterised at the voxel centres of REF's slices) with the model's
Eq. 11 labels on REF (`dynaslice labels MODEL --like REF.nii.gz`, one frame per written time).
Also checks the input's UIDs, ROI numbers, names and colours.

    python3 readback.py LIKE.dcm RS_DIR LABELS.nii.gz
"""
import sys, os
import numpy as np, nibabel as nib, pydicom
from skimage.measure import points_in_poly

like, rsdir, labels_path = sys.argv[1:4]
ref = pydicom.dcmread(like)
lab_img = nib.load(labels_path)
lab = np.asarray(lab_img.dataobj)
A = lab_img.affine
assert np.allclose(A[:3, :3], np.diag(np.diag(A[:3, :3]))), "axis-aligned grid expected"
sx, sy, sz = np.diag(A[:3, :3]); ox, oy, oz = A[:3, 3]
nx, ny, nz = lab.shape[:3]
X = ox + sx * np.arange(nx); Y = oy + sy * np.arange(ny)
GX, GY = np.meshgrid(X, Y, indexing="ij")
pts = np.stack([GX.ravel(), GY.ravel()], 1)
want_rois = {int(r.ROINumber): r.ROIName for r in ref.StructureSetROISequence}
want_colours = {int(c.ReferencedROINumber): [int(v) for v in c.ROIDisplayColor] for c in ref.ROIContourSequence}
entries = [l.split(" ", 1) for l in open(os.path.join(rsdir, "rtstruct.seq")) if l.strip() and not l.startswith("#")]
worst = {}
for f_index, (t, name) in enumerate(entries):
    ds = pydicom.dcmread(os.path.join(rsdir, name.strip()))
    same = (ds.StudyInstanceUID == ref.StudyInstanceUID,
            all(r.ReferencedFrameOfReferenceUID == ref.StructureSetROISequence[0].ReferencedFrameOfReferenceUID for r in ds.StructureSetROISequence),
            ds.PatientName == ref.PatientName)
    rois = {int(r.ROINumber): r.ROIName for r in ds.StructureSetROISequence}
    colours = {int(c.ReferencedROINumber): [int(v) for v in c.ROIDisplayColor] for c in ds.ROIContourSequence}
    ok_names = all(rois.get(k) == v and colours.get(k) == want_colours[k] for k, v in want_rois.items())
    line = [f"t={float(t):.3f} {name.strip()}: study/frame/patient same {same}, ROI numbers+names+colours as input {ok_names};"]
    for c in ds.ROIContourSequence:
        k = int(c.ReferencedROINumber)
        if k not in want_rois:
            continue
        region = np.zeros((nx, ny, nz), bool)
        for item in getattr(c, "ContourSequence", []):
            d = np.asarray(item.ContourData, float).reshape(-1, 3)
            ras = np.c_[-d[:, 0], -d[:, 1]]
            z = d[0, 2]
            kz = (z - oz) / sz
            assert abs(kz - round(kz)) < 1e-3, f"contour at z={z} off REF's slices"
            inside = points_in_poly(pts, ras).reshape(nx, ny)
            region[:, :, int(round(kz))] ^= inside
        model = lab[..., f_index] == k
        inter = (region & model).sum(); union = (region | model).sum()
        iou = inter / union if union else float("nan")
        worst[want_rois[k]] = min(worst.get(want_rois[k], 1.0), iou)
        line.append(f"{want_rois[k]} IoU {iou:.4f} ({region.sum()} vs {model.sum()} voxels)")
    print(" ".join(line), flush=True)
print("worst per class:", {k: round(v, 4) for k, v in worst.items()})
