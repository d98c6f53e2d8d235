#!/usr/bin/env python3
"""The inputs the README's command blocks name, made from the project's own synthetic data for
scripts/readme-blocks.sh (nothing from outside the project):

    readme-data.py TRUTH.nii.gz LABEL_NAMES OUT_DIR

- OUT_DIR/labels.nii.gz: `dynaslice synth`'s 4D ground truth (the three chambers, one frame
  per time, frames over the cycle [0, 1]) with 2 mm voxels, heart-sized (128 mm across) as a
  segmented cine MRI would be, RAS as NIfTI is;
- OUT_DIR/ct/CT_III.dcm: a planning CT series over the same box (axial slices every 2 mm,
  LPS as DICOM is; blank pixels: only its geometry is used);
- OUT_DIR/seed.dcm: an RT Structure Set of that patient and frame of reference with one ROI
  per class (LABEL_NAMES: `<label> <name>` lines) and a contour each, the `--like` from which
  scripts/readme-blocks.sh writes the phases that `dynaslice train phases.seq` reads.
"""
import os
import sys

import nibabel as nib
import numpy as np
from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.sequence import Sequence
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

VOXEL = 2.0  # mm


def main(truth, names_path, out):
    img = nib.load(truth)
    data = np.asarray(img.dataobj)
    nx, ny, nz = data.shape[:3]
    # Centred on the origin, 2 mm voxels.
    affine = np.diag([VOXEL, VOXEL, VOXEL, 1.0])
    affine[:3, 3] = [-(n - 1) * VOXEL / 2 for n in (nx, ny, nz)]
    labels = nib.Nifti1Image(data, affine, img.header.copy())
    labels.header.set_xyzt_units("mm", "sec")
    zooms = list(img.header.get_zooms())
    labels.header.set_zooms([VOXEL, VOXEL, VOXEL] + zooms[3:])
    labels.set_sform(affine, code=1)
    labels.set_qform(affine, code=1)
    nib.save(labels, os.path.join(out, "labels.nii.gz"))

    names = []
    for line in open(names_path):
        parts = line.split(maxsplit=1)
        if len(parts) == 2:
            names.append((int(parts[0]), parts[1].strip()))

    study, frame, series = generate_uid(), generate_uid(), generate_uid()

    def base(path, cls):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID = cls, generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
        ds.SOPClassUID, ds.SOPInstanceUID = cls, meta.MediaStorageSOPInstanceUID
        ds.StudyInstanceUID, ds.PatientName, ds.PatientID = study, "README^Example", "README"
        return ds

    # RAS (x, y) → LPS (−x, −y): the box's LPS corner with the smallest coordinates.
    lo_ras, hi_ras = affine[:3, 3], affine[:3, 3] + VOXEL * (np.array([nx, ny, nz]) - 1)
    corner = [-hi_ras[0], -hi_ras[1]]
    os.makedirs(os.path.join(out, "ct"), exist_ok=True)
    for k in range(nz):
        path = os.path.join(out, "ct", "CT_%03d.dcm" % k)
        ds = base(path, "1.2.840.10008.5.1.4.1.1.2")
        ds.Modality, ds.SeriesInstanceUID, ds.FrameOfReferenceUID = "CT", series, frame
        ds.InstanceNumber = k + 1
        ds.ImagePositionPatient = [float(corner[0]), float(corner[1]), float(lo_ras[2] + k * VOXEL)]
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.PixelSpacing, ds.Rows, ds.Columns = [VOXEL, VOXEL], ny, nx
        ds.SliceThickness = VOXEL
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.PixelData = np.zeros((ny, nx), np.int16).tobytes()
        ds.save_as(path, enforce_file_format=True)

    path = os.path.join(out, "seed.dcm")
    ds = base(path, "1.2.840.10008.5.1.4.1.1.481.3")
    ds.Modality, ds.StructureSetLabel = "RTSTRUCT", "README example"
    ref = Dataset()
    ref.FrameOfReferenceUID = frame
    ds.ReferencedFrameOfReferenceSequence = Sequence([ref])
    rois, contours = [], []
    for number, (label, name) in enumerate(names, start=1):
        roi = Dataset()
        roi.ROINumber, roi.ROIName, roi.ReferencedFrameOfReferenceUID = number, name, frame
        roi.ROIGenerationAlgorithm = "MANUAL"
        rois.append(roi)
        c = Dataset()
        c.ReferencedROINumber = number
        item = Dataset()
        item.ContourGeometricType, item.NumberOfContourPoints = "CLOSED_PLANAR", 4
        s = 4.0 * number
        item.ContourData = [-s, -s, 0.0, s, -s, 0.0, s, s, 0.0, -s, s, 0.0]
        c.ContourSequence = Sequence([item])
        contours.append(c)
    ds.StructureSetROISequence = Sequence(rois)
    ds.ROIContourSequence = Sequence(contours)
    ds.save_as(path, enforce_file_format=True)


if __name__ == "__main__":
    main(*sys.argv[1:4])
