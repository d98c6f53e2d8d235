"""A left ventricle contoured as cardiac tools draw it: the endocardium inside the epicardium,
one DICOM RT Structure Set per phase (pydicom), two phases at their trigger times in ms
(end-diastole 287.7 ms, end-systole 709.7 ms), short-axis planes every 5 mm.

The anatomy is analytic: epicardium and endocardium are nested prolate ellipsoids (the cavity
shifted 2 mm anterior), the wall 7-8 mm thick at end-diastole and thicker at end-systole, so
the contours are exact polygons of the true sections. The endocardium is drawn on its own
(not cut out of the epicardium): the epicardium's contour encloses it, as every contouring
tool draws them and the RT convention has it (GTV inside CTV inside PTV).

    python3 lab/cases/nested_heart.py OUT_DIR

writes, each a `.seq` manifest "<time ms> <file>" of RT Structure Sets in OUT_DIR:
- all.seq: every plane (5 mm), both ROIs; the reference for Simpson's rule;
- kept.seq: every other plane (10 mm), both ROIs; the training input;
- heldout.seq: the other planes, both ROIs; held-out scoring;
- kept_endo.seq, heldout_endo.seq: the same with the endocardium alone;
and OUT_DIR/case.json: per phase and ROI Simpson's volume (mL) from all.seq's contours
(Σ area × 5 mm) and the exact ellipsoid volume.
"""
import json
import math
import os
import sys

from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.sequence import Sequence
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

STEP = 5.0  # mm between contoured short-axis planes
PHASES = {"ED": 287.7, "ES": 709.7}  # trigger times, ms
# (centre, semi-axes) in RAS mm per phase: epicardium, endocardium.
SHAPES = {
    "ED": {"Epicardium": ((0.0, 0.0, 0.0), (31.0, 29.0, 52.0)),
           "Endocardium": ((0.0, 2.0, 3.0), (24.0, 22.0, 44.0))},
    "ES": {"Epicardium": ((0.0, 0.0, 2.0), (28.0, 27.0, 48.0)),
           "Endocardium": ((0.0, 2.0, 6.0), (17.0, 16.0, 37.0))},
}
NAMES = ["Epicardium", "Endocardium"]
COLORS = [[200, 60, 60], [240, 200, 60]]
VERTICES = 96


def planes():
    """z of every contoured plane (5 mm apart, symmetric about 0, covering every shape)."""
    reach = max(c[2] + a[2] for s in SHAPES.values() for c, a in s.values())
    n = int(reach // STEP) + 1
    return [STEP * (k + 0.5) for k in range(-n - 1, n + 1)]


def section(shape, z):
    """The ellipse (centre xy, semi-axes) cut by plane z, or None."""
    (cx, cy, cz), (ax, ay, az) = shape
    s = 1.0 - ((z - cz) / az) ** 2
    if s <= 1e-3:
        return None
    r = math.sqrt(s)
    return (cx, cy), (ax * r, ay * r)


def polygon(sec, z):
    (cx, cy), (ax, ay) = sec
    return [(cx + ax * math.cos(2 * math.pi * j / VERTICES),
             cy + ay * math.sin(2 * math.pi * j / VERTICES), z) for j in range(VERTICES)]


def polygon_area(sec):
    """The area of the drawn polygon (not of the ellipse): what Simpson's rule sums."""
    (_, _), (ax, ay) = sec
    return 0.5 * VERTICES * ax * ay * math.sin(2 * math.pi / VERTICES)


def write_rtstruct(path, polys, names, study, frame):
    """An RT Structure Set of `polys` {name: [RAS polygons]}, in LPS."""
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.481.3"
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "RTSTRUCT"
    ds.PatientName = "Phantom^LV"
    ds.PatientID = "LV001"
    ds.StructureSetLabel = os.path.basename(path)[:16]
    ds.StudyInstanceUID = study
    ds.SeriesInstanceUID = generate_uid()
    defined, contoured, observations = [], [], []
    for name in names:
        number = NAMES.index(name) + 1
        s = Dataset()
        s.ROINumber = number
        s.ROIName = name
        s.ReferencedFrameOfReferenceUID = frame
        s.ROIGenerationAlgorithm = "MANUAL"
        defined.append(s)
        c = Dataset()
        c.ReferencedROINumber = number
        c.ROIDisplayColor = COLORS[number - 1]
        items = []
        for poly in polys[name]:
            it = Dataset()
            it.ContourGeometricType = "CLOSED_PLANAR"
            it.NumberOfContourPoints = len(poly)
            it.ContourData = [f"{v:.4f}" for p in poly for v in (-p[0], -p[1], p[2])]
            items.append(it)
        c.ContourSequence = Sequence(items)
        contoured.append(c)
        o = Dataset()
        o.ObservationNumber = number
        o.ReferencedROINumber = number
        o.RTROIInterpretedType = "ORGAN"
        o.ROIInterpreter = ""
        observations.append(o)
    ds.StructureSetROISequence = Sequence(defined)
    ds.ROIContourSequence = Sequence(contoured)
    ds.RTROIObservationsSequence = Sequence(observations)
    ref = Dataset()
    ref.FrameOfReferenceUID = frame
    ds.ReferencedFrameOfReferenceSequence = Sequence([ref])
    ds.save_as(path, enforce_file_format=True)


def main(out):
    os.makedirs(out, exist_ok=True)
    study, frame = generate_uid(), generate_uid()
    zs = planes()
    sets = {
        "all": (range(len(zs)), NAMES),
        "kept": (range(0, len(zs), 2), NAMES),
        "heldout": (range(1, len(zs), 2), NAMES),
        "kept_endo": (range(0, len(zs), 2), ["Endocardium"]),
        "heldout_endo": (range(1, len(zs), 2), ["Endocardium"]),
    }
    simpson = {}
    for phase, t in PHASES.items():
        for set_name, (which, names) in sets.items():
            polys = {n: [] for n in names}
            for i in which:
                for n in names:
                    sec = section(SHAPES[phase][n], zs[i])
                    if sec is not None:
                        polys[n].append(polygon(sec, zs[i]))
            write_rtstruct(os.path.join(out, f"{set_name}_{phase}.dcm"), polys, names, study,
                           frame)
        for n in NAMES:
            areas = [polygon_area(s) for s in (section(SHAPES[phase][n], z) for z in zs) if s]
            (_, (a, b, c)) = SHAPES[phase][n]
            simpson[f"{phase} {n}"] = {
                "time_ms": t,
                "simpson_mL": round(sum(areas) * STEP / 1000.0, 3),
                "ellipsoid_mL": round(4.0 / 3.0 * math.pi * a * b * c / 1000.0, 3),
            }
    for set_name in sets:
        with open(os.path.join(out, f"{set_name}.seq"), "w") as f:
            for phase, t in PHASES.items():
                f.write(f"{t} {set_name}_{phase}.dcm\n")
    with open(os.path.join(out, "case.json"), "w") as f:
        json.dump({"step_mm": STEP, "planes": len(zs), "volumes": simpson}, f, indent=1)
    print(json.dumps(simpson))


if __name__ == "__main__":
    main(sys.argv[1])
