"""A thin-feature `.csl` case in OReX's style: a hand (an ellipsoidal palm and five fingers,
capsules a twentieth of the bounding box wide) cut by 15 planes (5 per axis) whose contours
are traced with scikit-image on a 0.05 mm grid of the exact implicit shape, and its reference
mesh (marching cubes of the same implicit at 0.25 mm, binary STL), in the coordinates of the
contours, like the shared `*_reference.stl`.

    python3 lab/cases/hand_csl.py OUT_DIR    # writes OUT_DIR/hand_thin.csl, hand_thin_reference.stl
    python3 lab/cases/hand_csl.py grid OUT_DIR              # OUT_DIR/hand_thin_truth.nii.gz
    python3 lab/cases/hand_csl.py score TRUTH.nii.gz PRED.nii.gz

`grid` writes the exact shape on a 0.5 mm grid over the box plus 2 mm (nibabel, RAS: the
`.csl` coordinates are the model's world frame) as the grid for `dynaslice labels MODEL --like
TRUTH -o PRED`; `score` prints the 3D IoU of label 1, the volume ratio, and the IoU of the
fingers alone (the voxels farther than 2 mm past the palm's ellipsoid, so the palm's bulk
cannot hide lost fingers).
"""
import os
import struct
import sys

import numpy as np
from skimage.measure import find_contours, marching_cubes

# Palm: ellipsoid centre and semi-axes (mm). Fingers: capsules (from, to), radius R.
PALM = (np.array([0.0, 0.0, 0.0]), np.array([20.0, 24.0, 7.0]))
R = 2.4  # the bounding box's longest side is about 96 mm: fingers 4.8 mm wide, a twentieth
FINGERS = [
    ((-15.0, 18.0, 0.0), (-19.0, 52.0, 0.0)),
    ((-5.0, 20.0, 0.0), (-6.0, 62.0, 0.0)),
    ((5.0, 20.0, 0.0), (6.0, 60.0, 0.0)),
    ((14.0, 18.0, 0.0), (18.0, 50.0, 0.0)),
    ((17.0, -8.0, 0.0), (36.0, 12.0, 0.0)),  # thumb
]


def inside(p):
    """Signed (negative inside) implicit: the union of the palm and the fingers; the fingers'
    values are exact distances, the palm's a scaled ellipsoid function."""
    c, a = PALM
    q = (p - c) / a
    d = (np.sqrt((q ** 2).sum(-1)) - 1.0) * a.min()
    for s, e in FINGERS:
        s, e = np.array(s), np.array(e)
        ab = e - s
        t = np.clip(((p - s) @ ab) / (ab @ ab), 0.0, 1.0)
        d = np.minimum(d, np.linalg.norm(p - (s + t[..., None] * ab), axis=-1) - R)
    return d


LO = np.array([-26.0, -30.0, -9.0])
HI = np.array([42.0, 66.0, 9.0])


def planes():
    """15 axis planes, 5 per axis, inside the box (axis, offset)."""
    out = []
    for axis in range(3):
        for f in np.linspace(0.15, 0.85, 5):
            out.append((axis, LO[axis] + f * (HI[axis] - LO[axis])))
    return out


def section(axis, offset, step=0.05):
    """Closed contours of the shape on the plane x[axis] = offset: lists of 3D points, solids
    counter-clockwise about the plane's +axis normal."""
    u, v = [a for a in range(3) if a != axis]
    gu = np.arange(LO[u] - 1, HI[u] + 1, step)
    gv = np.arange(LO[v] - 1, HI[v] + 1, step)
    P = np.zeros((len(gu), len(gv), 3))
    P[..., u] = gu[:, None]
    P[..., v] = gv[None, :]
    P[..., axis] = offset
    field = inside(P)
    out = []
    for c in find_contours(field, 0.0):
        if len(c) < 4 or np.allclose(c[0], c[-1]) is False:
            continue
        c = c[:-1][:: max(1, len(c) // 400)]  # at most ~400 vertices per contour
        # no two consecutive vertices alike as written (5 decimals): a zero-length edge is a
        # degenerate contour that `dynaslice` refuses
        q = np.round(gu[0] + c[:, 0] * step, 5), np.round(gv[0] + c[:, 1] * step, 5)
        keep = (q[0] != np.roll(q[0], 1)) | (q[1] != np.roll(q[1], 1))
        c = c[keep]
        pts = np.zeros((len(c), 3))
        pts[:, u] = gu[0] + c[:, 0] * step
        pts[:, v] = gv[0] + c[:, 1] * step
        pts[:, axis] = offset
        # orientation about the normal e_axis: (u, v, axis) is right-handed for axis 0 and 2
        area = 0.5 * np.sum(pts[:, u] * np.roll(pts[:, v], -1) - np.roll(pts[:, u], -1) * pts[:, v])
        right_handed = axis != 1
        if (area > 0) != right_handed:
            pts = pts[::-1]
        out.append(pts)
    return out


def write_csl(path):
    blocks = []
    for i, (axis, off) in enumerate(planes(), start=1):
        n = np.zeros(3)
        n[axis] = 1.0
        cs = section(axis, off)
        verts = np.concatenate(cs) if cs else np.zeros((0, 3))
        lines = [f"{i} {len(verts)} {len(cs)} {n[0]:g} {n[1]:g} {n[2]:g} {-off:.6f}"]
        lines += [f"{x:.5f} {y:.5f} {z:.5f}" for x, y, z in verts]
        k = 0
        for c in cs:
            lines.append(f"{len(c)} 1 " + " ".join(str(k + j) for j in range(len(c))))
            k += len(c)
        blocks.append("\n".join(lines))
    with open(path, "w") as f:
        f.write(f"CSLC\n{len(blocks)} 1\n\n" + "\n\n".join(blocks) + "\n")


def write_reference(path, step=0.25):
    axes = [np.arange(LO[a] - 2, HI[a] + 2, step) for a in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    field = inside(np.stack([X, Y, Z], -1))
    verts, faces, _, _ = marching_cubes(field, 0.0, spacing=(step,) * 3)
    verts += np.array([a[0] for a in axes])
    with open(path, "wb") as f:
        f.write(b"hand_thin reference".ljust(80, b" "))
        f.write(struct.pack("<I", len(faces)))
        for tri in faces:
            a, b, c = verts[tri]
            nrm = np.cross(b - a, c - a)
            nrm /= np.linalg.norm(nrm) or 1.0
            # marching_cubes winds outward for a field negative inside after flipping: write
            # (a, c, b) so normals point out of the negative region
            f.write(struct.pack("<12fH", *(-nrm), *a, *c, *b, 0))


GRID = 0.5


def grid_points():
    axes = [np.arange(LO[a] - 2, HI[a] + 2, GRID) for a in range(3)]
    return axes, np.stack(np.meshgrid(*axes, indexing="ij"), -1)


def write_grid(path):
    import nibabel as nib

    axes, p = grid_points()
    affine = np.diag([GRID, GRID, GRID, 1.0])
    affine[:3, 3] = [a[0] for a in axes]
    nib.save(nib.Nifti1Image((inside(p) <= 0).astype(np.uint8), affine), path)


def score(truth_path, pred_path):
    import json

    import nibabel as nib

    t = np.asarray(nib.load(truth_path).dataobj) == 1
    pr = np.asarray(nib.load(pred_path).dataobj) == 1
    if t.shape != pr.shape:
        sys.exit(f"{pred_path}: shape {pr.shape}, the truth's is {t.shape}")
    _, p = grid_points()
    c, a = PALM
    fingers = np.sqrt((((p - c) / (a + 2.0)) ** 2).sum(-1)) > 1.0
    iou = lambda m: float((t & pr & m).sum() / max(((t | pr) & m).sum(), 1))  # noqa: E731
    print(json.dumps({
        "iou": round(iou(np.ones_like(t)), 4),
        "iou_fingers": round(iou(fingers), 4),
        "volume_ratio": round(float(pr.sum() / t.sum()), 3),
    }))


if __name__ == "__main__":
    if sys.argv[1] == "grid":
        write_grid(os.path.join(sys.argv[2], "hand_thin_truth.nii.gz"))
        sys.exit()
    if sys.argv[1] == "score":
        score(sys.argv[2], sys.argv[3])
        sys.exit()
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    write_csl(os.path.join(out, "hand_thin.csl"))
    write_reference(os.path.join(out, "hand_thin_reference.stl"))
