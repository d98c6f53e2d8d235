"""A 4D CT contouring case as a radiotherapy physicist has it: ten breathing phases, both lungs
and a 17 mm tumour (GTV) riding the breathing 12 mm superior-inferior, contoured axially on
every 3rd CT slice (7.5 mm apart) on the even phases (or, with `--all`, on all ten), one DICOM
RT Structure Set per contoured phase (pydicom), listed in a `.seq` manifest "<time> <path>";
the ground truth is a 4D label NIfTI (nibabel) on the CT's 2.5 mm grid: the ten phases, or
with `--all` 37 times 0.1 s apart over the contoured range (0-3.6 s: between the phases too).

The anatomy is analytic, so contours and truth are exact: the lungs are ellipsoids whose bases
descend with inspiration, the GTV a ball inside the right lung, cut out of it (RTSTRUCT even-odd
rule: the GTV's circle inside the lung's contour is a hole of Lung_R, so the labels do not
overlap). World frame: NIfTI RAS mm; the DICOM files are LPS (x and y negated).

    python3 lab/cases/rtstruct4d.py OUT_DIR [--all]

writes OUT_DIR/phase_P.dcm (P = 0, 2, 4, 6, 8; with --all 0-9), OUT_DIR/phases.seq,
OUT_DIR/truth.nii.gz (labels 1 Lung_R, 2 Lung_L, 3 GTV; frame P at time 0.4·P s, with --all
frame F at 0.1·F s) and OUT_DIR/case.json (geometry, the contoured phases and the truth's
times, which lab/cases/score4d.py reads).
"""
import json
import math
import os
import sys

import nibabel as nib
import numpy as np
import pydicom
from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.sequence import Sequence
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

PHASES = 10
CONTOURED = [0, 2, 4, 6, 8]
PHASE_SECONDS = 0.4
ALL_TRUTH_FRAMES = 37  # --all: the truth every 0.1 s over phases 0-9
VOXEL = 2.5
SHAPE = (96, 64, 80)  # x, y, z voxels
ORIGIN = (-118.75, -78.75, -98.75)  # RAS centre of voxel (0, 0, 0)
EVERY = 3  # contour every 3rd slice: 7.5 mm
GTV_RADIUS = 8.5
GTV_TRAVEL = 12.0
NAMES = ["Lung_R", "Lung_L", "GTV"]
COLORS = [[80, 160, 255], [80, 255, 160], [255, 40, 40]]


def breath(phase):
    """0 at end-exhale (phase 0), 1 at end-inhale (phase 5)."""
    return 0.5 * (1.0 - math.cos(2.0 * math.pi * phase / PHASES))


def shapes(phase):
    """The phase's lungs (ellipsoids: centre, semi-axes; tops fixed, bases descend) and GTV
    (ball: centre, radius), RAS mm."""
    b = breath(phase)
    az_r, az_l = 75.0 + 6.0 * b, 70.0 + 6.0 * b
    lung_r = ((-55.0, 0.0, 70.0 - az_r), (40.0, 55.0, az_r))
    lung_l = ((55.0, 0.0, 65.0 - az_l), (38.0, 52.0, az_l))
    gtv = ((-50.0, 10.0, -20.0 - GTV_TRAVEL * b), GTV_RADIUS)
    return lung_r, lung_l, gtv


def ellipse_section(ell, z):
    """The ellipse (centre xy, semi-axes) cut from ellipsoid `ell` by plane z, or None."""
    (cx, cy, cz), (ax, ay, az) = ell
    s = 1.0 - ((z - cz) / az) ** 2
    if s <= 1e-4:
        return None
    r = math.sqrt(s)
    return (cx, cy), (ax * r, ay * r)


def ring(centre, axes, z, n):
    """A counter-clockwise n-gon on the ellipse, RAS."""
    return [
        (centre[0] + axes[0] * math.cos(2 * math.pi * j / n),
         centre[1] + axes[1] * math.sin(2 * math.pi * j / n), z)
        for j in range(n)
    ]


def contour_slices():
    """z of the contoured slices: every EVERY-th voxel centre."""
    return [ORIGIN[2] + VOXEL * i for i in range(0, SHAPE[2], EVERY)]


def contours(phase):
    """Per class, the closed polygons (RAS) of the phase on the contoured slices."""
    lung_r, lung_l, (gc, gr) = shapes(phase)
    out = {name: [] for name in NAMES}
    for z in contour_slices():
        dz = z - gc[2]
        gtv = None
        if abs(dz) < gr - 0.05:
            rr = math.sqrt(gr * gr - dz * dz)
            gtv = ring((gc[0], gc[1]), (rr, rr), z, 48)
            out["GTV"].append(gtv)
        for name, ell in (("Lung_R", lung_r), ("Lung_L", lung_l)):
            sec = ellipse_section(ell, z)
            if sec is None or min(sec[1]) < 0.5:
                continue
            out[name].append(ring(sec[0], sec[1], z, 128))
            if name == "Lung_R" and gtv is not None:
                out[name].append(gtv)  # a hole: even-odd inside the lung's outline
    return out


def truth(phase):
    """The phase's label volume (x, y, z), voxel centres inside each shape."""
    x = ORIGIN[0] + VOXEL * np.arange(SHAPE[0])
    y = ORIGIN[1] + VOXEL * np.arange(SHAPE[1])
    z = ORIGIN[2] + VOXEL * np.arange(SHAPE[2])
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    lung_r, lung_l, (gc, gr) = shapes(phase)
    lab = np.zeros(SHAPE, np.uint8)
    for value, ((cx, cy, cz), (ax, ay, az)) in ((1, lung_r), (2, lung_l)):
        lab[((X - cx) / ax) ** 2 + ((Y - cy) / ay) ** 2 + ((Z - cz) / az) ** 2 <= 1.0] = value
    lab[(X - gc[0]) ** 2 + (Y - gc[1]) ** 2 + (Z - gc[2]) ** 2 <= gr * gr] = 3
    return lab


def write_rtstruct(path, polys, study, frame):
    """An RT Structure Set (Explicit VR Little Endian) of `polys` {name: [RAS polygons]}, in LPS,
    in the study `study` and the Frame of Reference `frame` (one of each for all the phases of
    a 4D CT: the phases are images of one scanner frame, and `dynaslice train` refuses phases
    whose frames differ)."""
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.481.3"
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "RTSTRUCT"
    ds.PatientName = "Phantom^4DCT"
    ds.StructureSetLabel = os.path.basename(path)
    ds.StudyInstanceUID = study
    defined, contoured = [], []
    for number, name in enumerate(NAMES, start=1):
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
            # LPS: x and y negated (the order stays counter-clockwise seen along +z flipped;
            # RTSTRUCT orientation carries no meaning, the reader orients by nesting).
            it.ContourData = [f"{v:.4f}" for p in poly for v in (-p[0], -p[1], p[2])]
            items.append(it)
        c.ContourSequence = Sequence(items)
        contoured.append(c)
    ds.StructureSetROISequence = Sequence(defined)
    ds.ROIContourSequence = Sequence(contoured)
    ds.save_as(path, enforce_file_format=True)


def main(out, all_phases):
    os.makedirs(out, exist_ok=True)
    lines = []
    study, frame = generate_uid(), generate_uid()
    contoured = list(range(PHASES)) if all_phases else CONTOURED
    # truth at these (fractional) phases: breath() and shapes() are analytic in the phase
    if all_phases:
        truth_phases = [(PHASES - 1) * f / (ALL_TRUTH_FRAMES - 1) for f in range(ALL_TRUTH_FRAMES)]
    else:
        truth_phases = list(range(PHASES))
    for p in contoured:
        path = os.path.join(out, f"phase_{p}.dcm")
        write_rtstruct(path, contours(p), study, frame)
        lines.append(f"{PHASE_SECONDS * p:g} phase_{p}.dcm")
    with open(os.path.join(out, "phases.seq"), "w") as f:
        f.write("\n".join(lines) + "\n")
    vol = np.stack([truth(p) for p in truth_phases], axis=-1)
    affine = np.diag([VOXEL, VOXEL, VOXEL, 1.0])
    affine[:3, 3] = ORIGIN
    img = nib.Nifti1Image(vol, affine)
    img.header.set_xyzt_units("mm", "sec")
    img.header["pixdim"][4] = PHASE_SECONDS * (truth_phases[1] - truth_phases[0])
    nib.save(img, os.path.join(out, "truth.nii.gz"))
    counts = {n: int((vol == i + 1).sum()) for i, n in enumerate(NAMES)}
    with open(os.path.join(out, "case.json"), "w") as f:
        json.dump({"names": NAMES, "contoured_phases": contoured, "phase_seconds": PHASE_SECONDS,
                   "truth_phases": truth_phases, "voxel_mm": VOXEL,
                   "voxels_over_phases": counts}, f, indent=1)
    print(json.dumps(counts))


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--all"]
    if len(args) != 1:
        sys.exit(__doc__)
    main(args[0], "--all" in sys.argv[1:])
