"""A clinical RT Structure Set as a treatment planning system exports it (issue 51): a breast
case on axial planes 3 mm apart, made with pydicom, with the features that break a model fitted
off the planes:

- BODY cut by the scan at both ends (on every plane), with the arms as separate contours on the
  upper planes;
- Lung_L and Lung_R cropped at the top of the scan (their contours run to the last plane);
- Heart; Breast_L with a tumour-bed block inside it and the tumour bed inside that (nested two
  deep);
- small ROIs on 2, 3 and 6 planes (Borders, Nodes, Scar), and one ROI with no contour (PTV_eval).

Everything is analytic (ellipsoids and elliptic cylinders), so the contour stack and the truth
between planes are exact. World frame: DICOM patient LPS mm (x to the patient's left, y
posterior, z superior); ROI Number = label value.

    python3 lab/cases/clinical_rtstruct.py make DIR
        # DIR/RS.dcm (every plane), DIR/RS_kept.dcm (every other plane: the held-out protocol),
        # DIR/grid.nii.gz (the planes' 2 mm grid, for `dynaslice labels --like`), DIR/case.json
    python3 lab/cases/clinical_rtstruct.py itk DIR     # DIR/itk.nii.gz from RS_kept's planes
    python3 lab/cases/clinical_rtstruct.py score DIR MODEL.dsm [HELDOUT_LABELS.nii.gz]
        # one JSON object: per ROI the stack volume, the model's (`dynaslice measure --json`),
        # their ratio, how far its surface reaches past its first / last contour plane and past
        # its contours' box; with a label volume of a model trained on RS_kept.dcm, the
        # held-out-plane Dice of the model and of ITK's morphological contour interpolation.

`dynaslice` must be on PATH (or DYNASLICE names the binary).
"""
import json
import math
import os
import subprocess
import sys

import nibabel as nib
import numpy as np
import pydicom
from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.sequence import Sequence
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

SPACING = 3.0
PLANES = [-144.0 + SPACING * i for i in range(98)]  # the scan: 98 axial planes, 291 mm
PIXEL = 2.0
GRID_X = np.arange(-260.0, 260.0 + 1e-9, PIXEL)
GRID_Y = np.arange(-130.0, 130.0 + 1e-9, PIXEL)

# (number, name, colour, solids): a solid is ("cyl", cx, cy, ax, ay, z0, z1) (an elliptic
# cylinder) or ("ell", cx, cy, cz, ax, ay, az) (an ellipsoid). Several solids of one ROI are
# disjoint, so a plane's contours of one ROI never nest.
ROIS = [
    (1, "BODY", [200, 180, 140], [
        ("cyl", 0.0, 0.0, 170.0, 110.0, -1e9, 1e9),
        ("cyl", 215.0, 10.0, 32.0, 40.0, 40.0, 1e9),
        ("cyl", -215.0, 10.0, 32.0, 40.0, 40.0, 1e9),
    ]),
    (2, "Lung_L", [80, 255, 160], [("ell", 90.0, 25.0, 60.0, 55.0, 55.0, 130.0)]),
    (3, "Lung_R", [80, 160, 255], [("ell", -90.0, 25.0, 60.0, 55.0, 55.0, 130.0)]),
    (4, "Heart", [255, 60, 60], [("ell", 0.0, -10.0, -45.0, 32.0, 40.0, 50.0)]),
    (5, "Breast_L", [255, 170, 200], [("ell", 90.0, -60.0, 0.0, 45.0, 22.0, 55.0)]),
    (6, "TB_block", [255, 255, 0], [("ell", 95.0, -60.0, 4.5, 20.0, 12.0, 19.0)]),
    (7, "TumourBed", [255, 120, 0], [("ell", 95.0, -60.0, 4.5, 10.0, 6.0, 10.0)]),
    (8, "Nodes", [0, 200, 200], [("ell", 40.0, -80.0, 90.0, 6.0, 6.0, 5.5)]),
    (9, "Scar", [160, 0, 200], [("ell", 90.0, -85.5, -1.5, 12.0, 2.0, 9.0)]),
    (10, "Borders", [120, 120, 120], [("ell", -60.0, -80.0, -16.5, 30.0, 10.0, 3.0)]),
    (11, "PTV_eval", [255, 0, 255], []),
]
# Nesting as drawn: each ROI's label volume keeps only what no ROI nested in it covers.
INNER = {5: [6, 7], 6: [7]}


def section(solid, z):
    """(centre xy, semi-axes) of `solid` on plane z, or None."""
    if solid[0] == "cyl":
        _, cx, cy, ax, ay, z0, z1 = solid
        return ((cx, cy), (ax, ay)) if z0 <= z <= z1 else None
    _, cx, cy, cz, ax, ay, az = solid
    s = 1.0 - ((z - cz) / az) ** 2
    if s <= 1e-3:
        return None
    r = math.sqrt(s)
    return (cx, cy), (ax * r, ay * r)


def ring(sec, z, n=96):
    (cx, cy), (ax, ay) = sec
    return [(cx + ax * math.cos(2 * math.pi * j / n), cy + ay * math.sin(2 * math.pi * j / n), z)
            for j in range(n)]


def polygon_area(poly):
    return 0.5 * abs(sum(p[0] * q[1] - q[0] * p[1] for p, q in zip(poly, poly[1:] + poly[:1])))


def contours(planes):
    """{number: [polygons]} on `planes`."""
    out = {n: [] for n, *_ in ROIS}
    for number, _, _, solids in ROIS:
        for z in planes:
            for solid in solids:
                sec = section(solid, z)
                if sec is not None and min(sec[1]) > 0.5:
                    out[number].append(ring(sec, z))
    return out


def write_rtstruct(path, polys):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.481.3"
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "RTSTRUCT"
    ds.PatientName = "Phantom^Breast"
    ds.StructureSetLabel = "breast"
    frame = generate_uid()
    defined, contoured = [], []
    for number, name, colour, _ in ROIS:
        s = Dataset()
        s.ROINumber = number
        s.ROIName = name
        s.ReferencedFrameOfReferenceUID = frame
        s.ROIGenerationAlgorithm = "MANUAL"
        defined.append(s)
        c = Dataset()
        c.ReferencedROINumber = number
        c.ROIDisplayColor = colour
        items = []
        for poly in polys[number]:
            it = Dataset()
            it.ContourGeometricType = "CLOSED_PLANAR"
            it.NumberOfContourPoints = len(poly)
            it.ContourData = [f"{v:.3f}" for p in poly for v in p]
            items.append(it)
        c.ContourSequence = Sequence(items)
        contoured.append(c)
    ds.StructureSetROISequence = Sequence(defined)
    ds.ROIContourSequence = Sequence(contoured)
    ds.save_as(path, enforce_file_format=True)


def labels_on(planes):
    """The disjoint label map (x, y, plane) of the ROIs on `planes` (inner ROIs over outer)."""
    X, Y = np.meshgrid(GRID_X, GRID_Y, indexing="ij")
    out = np.zeros((len(GRID_X), len(GRID_Y), len(planes)), np.uint8)
    for k, z in enumerate(planes):
        for number, _, _, solids in ROIS:  # in ROI order: nested ROIs come after their outer
            for solid in solids:
                sec = section(solid, z)
                if sec is None or min(sec[1]) <= 0.5:
                    continue
                (cx, cy), (ax, ay) = sec
                out[..., k][((X - cx) / ax) ** 2 + ((Y - cy) / ay) ** 2 <= 1.0] = number
    return out


def affine():
    a = np.diag([PIXEL, PIXEL, SPACING, 1.0])
    a[:3, 3] = [GRID_X[0], GRID_Y[0], PLANES[0]]
    # NIfTI is RAS: LPS x and y negated.
    return np.diag([-1.0, -1.0, 1.0, 1.0]) @ a


def stack_volumes(polys):
    """Per ROI as drawn (nested ones included): Σ contour areas × spacing, mm³."""
    return {n: sum(polygon_area(p) for p in polys[n]) * SPACING for n, *_ in ROIS}


def make(d):
    os.makedirs(d, exist_ok=True)
    polys = contours(PLANES)
    write_rtstruct(os.path.join(d, "RS.dcm"), polys)
    write_rtstruct(os.path.join(d, "RS_kept.dcm"), contours(PLANES[::2]))
    nib.save(nib.Nifti1Image(labels_on(PLANES), affine()), os.path.join(d, "grid.nii.gz"))
    planes_of = {n: sorted({p[0][2] for p in polys[n]}) for n, *_ in ROIS}
    case = {
        "spacing": SPACING,
        "rois": [{
            "number": n, "name": name, "planes": len(planes_of[n]),
            "first": planes_of[n][0] if planes_of[n] else None,
            "last": planes_of[n][-1] if planes_of[n] else None,
            "box_lps": [[min(p[i] for q in polys[n] for p in q) for i in range(3)],
                        [max(p[i] for q in polys[n] for p in q) for i in range(3)]]
            if polys[n] else None,
            "stack_ml": stack_volumes(polys)[n] / 1000.0,
        } for n, name, *_ in ROIS],
    }
    with open(os.path.join(d, "case.json"), "w") as f:
        json.dump(case, f, indent=1)
    print(json.dumps({r["name"]: [r["planes"], round(r["stack_ml"], 2)] for r in case["rois"]}))


def itk(d):
    import itk as itk_
    full = np.asarray(nib.load(os.path.join(d, "grid.nii.gz")).dataobj)
    sparse = full.copy()
    sparse[..., 1::2] = 0
    img = itk_.GetImageFromArray(np.ascontiguousarray(sparse.transpose(2, 1, 0)))
    filled = itk_.morphological_contour_interpolator(img, axis=2)
    out = itk_.GetArrayFromImage(filled).transpose(2, 1, 0).astype(np.uint8)
    nib.save(nib.Nifti1Image(out, affine()), os.path.join(d, "itk.nii.gz"))


def dice(a, b):
    s = a.sum() + b.sum()
    return float(2.0 * (a & b).sum() / s) if s else 1.0


def score(d, model, heldout=None):
    with open(os.path.join(d, "case.json")) as f:
        case = json.load(f)
    exe = os.environ.get("DYNASLICE", "dynaslice")
    m = json.loads(subprocess.run([exe, "measure", model, "--json"], check=True,
                                  capture_output=True, text=True).stdout)
    out = {}
    if heldout:
        truth = np.asarray(nib.load(os.path.join(d, "grid.nii.gz")).dataobj)[..., 1::2]
        pred = np.asarray(nib.load(heldout).dataobj)[..., 1::2]
        ref = np.asarray(nib.load(os.path.join(d, "itk.nii.gz")).dataobj)[..., 1::2]
    for roi in case["rois"]:
        if roi["first"] is None:
            continue
        c = next((c for c in m["classes"] if c["name"] == roi["name"]), None)
        row = {"planes": roi["planes"], "stack_ml": round(roi["stack_ml"], 3)}
        if c is not None:
            row.update(volume_row(c, roi))
        if heldout:
            n = roi["number"]
            inner = INNER.get(n, [])
            t = np.isin(truth, [n] + inner)
            row["held_dice"] = round(dice(t, np.isin(pred, [n] + inner)), 4)
            row["itk_dice"] = round(dice(t, np.isin(ref, [n] + inner)), 4)
        out[roi["name"]] = row
    print(json.dumps(out, indent=1))


def volume_row(c, roi):
    """The model's volume against the stack's, and its reach past the ROI's end planes and box
    (mm), from `measure --json`'s class entry (a static model: its one time; volume mL,
    bounding box in LPS mm)."""
    vol = c["volume_ml"][0]
    row = {"model_ml": round(vol, 3), "ratio": round(vol / roi["stack_ml"], 3)}
    box = c["bounding_box"][0]
    if box:
        lo, hi = box["min"], box["max"]
        row["past_first_mm"] = round(roi["first"] - lo[2], 1)
        row["past_last_mm"] = round(hi[2] - roi["last"], 1)
        blo, bhi = roi["box_lps"]
        row["past_box_mm"] = round(max(max(blo[i] - lo[i], hi[i] - bhi[i]) for i in range(3)), 1)
    return row


if __name__ == "__main__":
    a = sys.argv[1:]
    if len(a) == 2 and a[0] == "make":
        make(a[1])
    elif len(a) == 2 and a[0] == "itk":
        itk(a[1])
    elif len(a) in (3, 4) and a[0] == "score":
        score(a[1], a[2], a[3] if len(a) == 4 else None)
    else:
        sys.exit(__doc__)
