"""Reference NIfTI headers for the readback: 1 mm in-plane over the truth's extent, the truth's
2.5 mm slices (z), N frames DT s apart.  python3 mkref.py OUT N DT"""
import sys, numpy as np, nibabel as nib
out, n, dt = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
shape = (240, 160, 80, n)
aff = np.diag([1.0, 1.0, 2.5, 1.0]); aff[:3, 3] = (-119.5, -79.5, -98.75)
img = nib.Nifti1Image(np.zeros(shape, np.uint8), aff)
img.header.set_xyzt_units("mm", "sec"); img.header["pixdim"][4] = dt
nib.save(img, out)
