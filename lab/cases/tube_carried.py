"""How much of the swaying tube's motion a motion model's u carries (lab/cases/tube4d.py).

At the true centre of the tube in three axial slabs, at every second frame that moved more than
5 mm from frame 0, the part of the true travel x_t − x_0 that u leaves: the distance
|x_t + u(x_t, t) − (x_0 + u(x_0, 0))| (zero where u carries the point exactly), as a share of
the travel. u is read with `dynaslice query` (its last line).

    python3 lab/cases/tube_carried.py TUBE4D.nii.gz MODEL.dsm [DYNASLICE]

Prints one line: the frames used, the true travel's median, the median left, and the share
carried (1 − median of left / travel).
"""
import subprocess
import sys

import nibabel as nib
import numpy as np

FRAME_SECONDS = 0.1  # tube4d.py's pixdim[4]
SLABS = (20, 36, 52)


def displacement(dynaslice, model, x, t):
    out = subprocess.run([dynaslice, "query", model, "--", *[f"{v:.4f}" for v in x], f"{t:.4f}"],
                         capture_output=True, text=True, check=True).stdout
    line = next(l for l in out.splitlines() if l.startswith("displacement"))
    return np.array([float(v) for v in line.split()[1:4]])


def main():
    truth, model = sys.argv[1], sys.argv[2]
    dynaslice = sys.argv[3] if len(sys.argv) > 3 else "dynaslice"
    img = nib.load(truth)
    labels = np.asarray(img.dataobj)
    frames = labels.shape[3]
    rows = []
    for z in SLABS:
        centres = {}
        for f in range(0, frames, 2):
            ij = np.argwhere(labels[:, :, z, f] > 0).mean(0)
            centres[f] = (img.affine @ np.array([ij[0], ij[1], z, 1.0]))[:3]
        x0 = centres[0]
        y0 = x0 + displacement(dynaslice, model, x0, 0.0)
        for f, xt in centres.items():
            travel = np.linalg.norm(xt - x0)
            if f == 0 or travel < 5.0:
                continue
            t = f * FRAME_SECONDS
            left = np.linalg.norm(xt + displacement(dynaslice, model, xt, t) - y0)
            rows.append((travel, left))
    r = np.array(rows)
    print(f"{model}: {len(r)} frames, true travel median {np.median(r[:, 0]):.1f} mm, "
          f"left median {np.median(r[:, 1]):.1f} mm, share carried "
          f"{1 - np.median(r[:, 1] / r[:, 0]):.2f}")


if __name__ == "__main__":
    main()
