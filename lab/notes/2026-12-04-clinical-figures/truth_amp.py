"""Centroid of each truth label per phase from rt/truth.nii.gz, in RAS mm (via the affine), and its peak-to-peak range."""
import sys, json
import nibabel as nib, numpy as np
img = nib.load(sys.argv[1])
a = img.affine
lab = np.asarray(img.dataobj)
print("shape", lab.shape, "affine\n", a)
names = {1: "Lung_R", 2: "Lung_L", 3: "GTV"}
for v, n in names.items():
    cs = []
    for p in range(lab.shape[3]):
        idx = np.argwhere(lab[..., p] == v).astype(float)
        c = (a[:3, :3] @ idx.mean(0)) + a[:3, 3]
        cs.append(c)
    cs = np.array(cs)
    print(n, "centroid per phase (RAS mm):")
    for p, c in enumerate(cs):
        print(f"  phase {p} t={0.4*p:.1f}s  {c[0]:9.3f} {c[1]:9.3f} {c[2]:9.3f}  voxels {(lab[...,p]==v).sum()}")
    ptp = cs.max(0) - cs.min(0)
    print(f"  peak-to-peak all 10 phases: LR {ptp[0]:.3f} AP {ptp[1]:.3f} SI {ptp[2]:.3f} mm")
    sub = cs[:9]
    ptp = sub.max(0) - sub.min(0)
    print(f"  peak-to-peak phases 0-8 (t 0..3.2 s): LR {ptp[0]:.3f} AP {ptp[1]:.3f} SI {ptp[2]:.3f} mm")
    sub = cs[[0,2,4,6,8]]
    ptp = sub.max(0) - sub.min(0)
    print(f"  peak-to-peak contoured phases 0,2,4,6,8: LR {ptp[0]:.3f} AP {ptp[1]:.3f} SI {ptp[2]:.3f} mm")
