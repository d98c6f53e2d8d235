"""Between sparse parallel slices (issue 48): what the field does midway between kept slices,
against the truth's 3D signed distance, and how far apart neighbouring kept contours are.

    python3 between.py ring DIR [MODEL]           # lab/cases/cine_ring.py's case (kept 20 mm)
    python3 between.py lesion DIR GAP [MODEL]     # lab/cases/lesion.py's case (kept GAP mm)

One JSON line per (phase, class): first the neighbouring kept contours ("pairs": per pair of
kept slices that both show the class, their 2D Dice, the mean and largest distance from one
contour to the other, and the structure's width 2·area/perimeter, mm), then per held-out slice
(s: its position between its two kept neighbours, 0.5 midway):
- the truth's 3D signed distance at its deepest pixel ("true_min") and, with MODEL, the
  model's own channel there ("f_at_deepest"), its mean over the truth's inside ("f_in",
  against the truth's "sdf_in"), the share of the truth's inside where the channel is positive
  ("lost", the channel alone, not Eq. 11's argmin) and the channel's Dice;
- "blend": the neighbours' 2D signed distances mixed linearly by s (shape-based interpolation:
  what a target between the planes from the neighbouring contours would say), its Dice
  against the truth and its mean over the truth's inside;
and the same model columns on the kept slices ("kept").
The truth's 3D distance comes from the case's own generator on a grid 3 (lesion) or 7 (ring)
times finer across the slices, so it is exact to about a pixel.
"""
import json
import os
import sys

import nibabel as nib
import numpy as np
from scipy import ndimage

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "cases"))


def sdf3(mask, spacing):
    """Signed distance (mm, negative inside) of a boolean volume, to about half a voxel."""
    h = 0.5 * min(spacing)
    if not mask.any():
        return np.full(mask.shape, np.inf)
    out = ndimage.distance_transform_edt(~mask, sampling=spacing) - h
    ins = ndimage.distance_transform_edt(mask, sampling=spacing) - h
    return np.where(mask, -ins, out)


def contour(mask):
    return mask & ~ndimage.binary_erosion(mask)


def dice(a, b):
    s = a.sum() + b.sum()
    return 1.0 if s == 0 else float(2 * (a & b).sum() / s)


def ring_case(d):
    import cine_ring as c

    truth = np.asarray(nib.load(os.path.join(d, "truth.nii.gz")).dataobj)
    n = 7  # fine slice 7m + 3 is truth slice m (z = (k + 0.5)·10/7 = 10m + 5)
    c.NZ, c.SLICE = c.NZ * n, c.SLICE / n
    fine = np.stack([c.phase(False), c.phase(True)], axis=-1)
    c.NZ, c.SLICE = c.NZ // n, c.SLICE * n
    aff = nib.load(os.path.join(d, "truth.nii.gz")).affine
    return dict(
        truth=truth, fine=fine, n=n, off=3, fine_spacing=(c.PIXEL, c.PIXEL, c.SLICE / n),
        pixel=c.PIXEL, affine=aff, kept=c.kept_slices(), names=c.NAMES, times=[0.0, c.DT],
        phases=["ED", "ES"],
    )


def lesion_case(d, gap):
    import lesion as c

    c.load_shape(d)
    truth = np.asarray(nib.load(os.path.join(d, "truth.nii.gz")).dataobj)[..., None]
    n = 3  # fine slice 3m is truth slice m
    radius = json.load(open(os.path.join(d, "case.json")))["radius"]
    nz, sl = c.SHAPE[2], c.SLICE
    c.SHAPE[2], c.SLICE = n * (nz - 1) + 1, sl / n
    fine = c.volume(radius)[..., None]
    c.SHAPE[2], c.SLICE = nz, sl
    aff = nib.load(os.path.join(d, "truth.nii.gz")).affine
    return dict(
        truth=truth, fine=fine, n=n, off=0, fine_spacing=(c.PIXEL, c.PIXEL, sl / n),
        pixel=c.PIXEL, affine=aff, kept=c.kept(gap)[0], names=c.NAMES, times=[0.0],
        phases=["static"],
    )


def run(case, model_path):
    model = None
    if model_path:
        sys.path.insert(0, HERE)
        from dsm import Model

        model = Model(model_path)
    truth, fine, kept = case["truth"], case["fine"], case["kept"]
    nx, ny, nz = truth.shape[:3]
    ii, jj = np.indices((nx, ny))
    px = case["pixel"]
    held = [z for z in range(kept[0] + 1, kept[-1]) if z not in kept]
    for t, ph in enumerate(case["phases"]):
        for lab, name in case["names"].items():
            fmask = fine[..., t] == lab
            if not fmask.any():
                continue
            sd = sdf3(fmask, case["fine_spacing"])
            true_sdf = lambda z: sd[:, :, case["n"] * z + case["off"]]
            sd2 = {}
            for z in kept:
                m = truth[:, :, z, t] == lab
                sd2[z] = sdf3(m, (px, px)) if m.any() else None
            pairs = []
            for a, b in zip(kept, kept[1:]):
                ma, mb = truth[:, :, a, t] == lab, truth[:, :, b, t] == lab
                if not (ma.any() and mb.any()):
                    continue
                ca, cb = contour(ma), contour(mb)
                da = ndimage.distance_transform_edt(~cb, sampling=(px, px))[ca]
                db = ndimage.distance_transform_edt(~ca, sampling=(px, px))[cb]
                both = np.concatenate([da, db])
                width = np.mean([2 * m.sum() * px * px / (contour(m).sum() * px) for m in (ma, mb)])
                pairs.append(
                    dict(slices=[a, b], dice2d=round(dice(ma, mb), 3),
                         mean_mm=round(float(both.mean()), 1), max_mm=round(float(both.max()), 1),
                         width_mm=round(float(width), 1))
                )
            row = dict(phase=ph, cls=name, pairs=pairs, held={}, kept={})

            def field(z):
                xyz = np.stack([ii.ravel(), jj.ravel(), np.full(ii.size, z), np.ones(ii.size)])
                w = (case["affine"] @ xyz)[:3].T
                return model.f(w, case["times"][t])[:, lab - 1].reshape(nx, ny)

            def model_cols(z, out):
                T = truth[:, :, z, t] == lab
                if model is None or not T.any():
                    return
                f, s3 = field(z), true_sdf(z)
                deep = np.unravel_index(np.argmin(np.where(T, s3, np.inf)), s3.shape)
                out.update(
                    true_min=round(float(s3[deep]), 2), f_at_deepest=round(float(f[deep]), 2),
                    sdf_in=round(float(s3[T].mean()), 2), f_in=round(float(f[T].mean()), 2),
                    lost=round(float((f[T] > 0).mean()), 3), dice=round(dice(T, f < 0), 3),
                )

            for z in held:
                lo = max(k for k in kept if k < z)
                hi = min(k for k in kept if k > z)
                T = truth[:, :, z, t] == lab
                if not T.any() and sd2[lo] is None and sd2[hi] is None:
                    continue
                s = (z - lo) / (hi - lo)
                cell = dict(s=round(s, 2), true_px=int(T.sum()))
                if sd2[lo] is not None and sd2[hi] is not None:
                    bl = (1 - s) * sd2[lo] + s * sd2[hi]
                    cell["blend_dice"] = round(dice(T, bl < 0), 3)
                    if T.any():
                        cell["blend_in"] = round(float(bl[T].mean()), 2)
                model_cols(z, cell)
                row["held"][z] = cell
            for z in kept:
                cell = {}
                model_cols(z, cell)
                if cell:
                    row["kept"][z] = cell
            print(json.dumps(row))


if __name__ == "__main__":
    a = sys.argv[1:]
    if len(a) in (2, 3) and a[0] == "ring":
        run(ring_case(a[1]), a[2] if len(a) == 3 else None)
    elif len(a) in (3, 4) and a[0] == "lesion":
        run(lesion_case(a[1], int(a[2])), a[3] if len(a) == 4 else None)
    else:
        sys.exit(__doc__)
