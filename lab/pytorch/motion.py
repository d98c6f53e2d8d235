#!/usr/bin/env python3
"""Design experiments for the motion model (issue 45), in PyTorch: which model class and which
loss carry a structure that moves farther than its width between annotated times.

Not the product: a research reference, run by hand, whose figures the lab note
lab/notes/2026-12-07-motion-model.md quotes. The data are a 4D label NIfTI (a lab case's
truth), cut into planes the way the trainer cuts them:

- `reslice`: the paper's protocol (dynaslice-data reslice.rs): 20 planes rotated about the z
  axis through the labelled box's centre, and every 2nd axial slice of the labelled range;
- `axial:K`: every K-th axial slice (contours of a 4D CT drawn every K-th slice).

Each plane becomes a grid of points at half the voxel size with each class's exact 2D signed
distance (scipy's EDT of the plane's nearest-neighbour labels). The losses are the trainer's
(Eq. 5, 7, 8, 10; the orientation term left out): |f| on contour points, lambda_d (f - sdf2d)^2
on plane samples, lambda_r [(|grad f| - 1)^2 + exp(-alpha |f|)] on space-time samples.

Models (`--model`):
- `point`: today's model, f(x, t) a SIREN of (x, t), first-layer omega_t clamped (Eq. 2, 4);
- `warp`: f(x, t) = g(x + u(x, t), t), g today's SIREN (its omega_t bound scaled by
  `--shape-band`), u a small SIREN of (x, t) with three outputs (zero at the start), its
  first-layer omega_t clamped by Eq. 4 with `--motion-factor`. The eikonal term applies to g in
  its own (canonical) frame at the warped space-time samples' points; u is kept smooth by
  lambda_j |J_u|_F^2 and free of folds by ReLU(0.2 - det(I + J_u)).

    python3 lab/pytorch/motion.py TRUTH.nii.gz --frames 0:37:4 --planes reslice --model warp
        [--steps 1000] [--seed 1] [--labels 1,2,3]

prints one JSON line: IoU per class pooled over every truth frame, the worst frame, the trained
frames' IoU, the volume ratio range, the centroid's peak-to-peak travel per axis (mm) against
the truth's, and seconds.
"""

import argparse
import json
import math
import time

import nibabel as nib
import numpy as np
import torch
from scipy.ndimage import distance_transform_edt as edt
from scipy.ndimage import map_coordinates


def parse_frames(s, n):
    a, b, c = (int(v) for v in s.split(":"))
    return list(range(a, min(b, n), c))


def plane_grids(shape, affine, lo, hi, planes):
    """World-space grids (list of (P, 3) arrays and their 2D shape) of the protocol's planes."""
    vox = np.sqrt((affine[:3, :3] ** 2).sum(0))
    pixel = 0.5 * vox.min()
    out = []
    if planes == "reslice":
        centre_v = 0.5 * (lo + hi)
        half = 0.5 * (hi - lo + 4) * vox
        radius = np.linalg.norm(half[:2])
        zs = np.arange(-half[2], half[2] + 1e-9, pixel)
        rs = np.arange(-radius, radius + 1e-9, pixel)
        for j in range(20):
            th = math.pi * j / 20
            d = np.array([math.cos(th), math.sin(th), 0.0])
            r, z = np.meshgrid(rs, zs, indexing="ij")
            pts_mm = r[..., None] * d + z[..., None] * np.array([0, 0, 1.0])
            out.append((pts_mm + centre_v * vox, r.shape))
        ks = range(lo[2], hi[2] + 1, 2)
    else:
        every = int(planes.split(":")[1])
        ks = range(lo[2], hi[2] + 1, every)
    for k in ks:
        xs = np.arange((lo[0] - 2) * vox[0], (hi[0] + 2) * vox[0] + 1e-9, pixel)
        ys = np.arange((lo[1] - 2) * vox[1], (hi[1] + 2) * vox[1] + 1e-9, pixel)
        x, y = np.meshgrid(xs, ys, indexing="ij")
        pts_mm = np.stack([x, y, np.full_like(x, k * vox[2])], -1)
        out.append((pts_mm, x.shape))
    return out, pixel, vox


def build_data(data, frames, labels, planes, vox_affine):
    """Per trained frame: points (mm, voxel-index frame scaled), per-class 2D SDFs (mm)."""
    occupied = np.argwhere((data[..., frames] > 0).any(-1))
    lo, hi = occupied.min(0), occupied.max(0)
    grids, pixel, vox = plane_grids(data.shape[:3], vox_affine, lo, hi, planes)
    per_frame = []
    for f in frames:
        vol = data[..., f]
        pts_all, sdf_all = [], []
        for pts_mm, shp in grids:
            idx = (pts_mm / vox).reshape(-1, 3).T
            lab = map_coordinates(vol, idx, order=0, mode="constant", cval=0).reshape(shp)
            sdfs = []
            for c in labels:
                m = lab == c
                if m.any():
                    s = (edt(~m) - edt(m)) * pixel
                    s = np.where(m, s + 0.5 * pixel, s - 0.5 * pixel)
                else:
                    s = np.full(shp, 1e3)
                sdfs.append(s.reshape(-1))
            pts_all.append(pts_mm.reshape(-1, 3))
            sdf_all.append(np.stack(sdfs, -1))
        per_frame.append((np.concatenate(pts_all), np.concatenate(sdf_all)))
    return per_frame, lo, hi, vox, pixel


class Siren(torch.nn.Module):
    """SIREN with omega_0 folded into the weights, the first layer's time column apart."""

    def __init__(self, n_in, widths, n_out, omega0, t_max, zero_out=False, offset=0.0):
        super().__init__()
        self.wx = torch.nn.Parameter(torch.empty(widths[0], n_in).uniform_(-1 / n_in, 1 / n_in) * omega0)
        self.wt = torch.nn.Parameter(torch.empty(widths[0]).uniform_(-1, 1) * min(omega0 / 4, t_max))
        self.b0 = torch.nn.Parameter(torch.empty(widths[0]).uniform_(-1, 1))
        self.t_max = t_max
        self.hidden = torch.nn.ModuleList()
        for a, b in zip(widths[:-1], widths[1:]):
            lin = torch.nn.Linear(a, b)
            with torch.no_grad():
                lin.weight.uniform_(-math.sqrt(6 / a), math.sqrt(6 / a))
                lin.bias.uniform_(-1 / math.sqrt(a), 1 / math.sqrt(a))
            self.hidden.append(lin)
        self.out = torch.nn.Linear(widths[-1], n_out)
        with torch.no_grad():
            if zero_out:
                self.out.weight.mul_(1e-3)
                self.out.bias.zero_()
            else:
                self.out.weight.uniform_(-math.sqrt(6 / widths[-1]), math.sqrt(6 / widths[-1]))
                self.out.bias.fill_(offset)

    def forward(self, x, t):
        h = torch.sin(x @ self.wx.T + t[:, None] * self.wt + self.b0)
        for lin in self.hidden:
            h = torch.sin(lin(h))
        return self.out(h)

    def project(self):
        with torch.no_grad():
            self.wt.clamp_(-self.t_max, self.t_max)


class Model(torch.nn.Module):
    def __init__(self, args, k, dt):
        super().__init__()
        t_max = 0.2 * math.pi / dt
        self.kind = args.model
        self.g = Siren(3, [args.width] * args.depth, k, 20.0, t_max * args.shape_band, offset=0.2)
        if self.kind == "warp":
            self.u = Siren(3, [args.motion_width] * 2, 3, args.motion_omega,
                           args.motion_factor * math.pi / dt, zero_out=True)

    def warp(self, x, t):
        return x + self.u(x, t) if self.kind == "warp" else x

    def forward(self, x, t):
        return self.g(self.warp(x, t), t)

    def project(self):
        self.g.project()
        if self.kind == "warp":
            self.u.project()


def main():
    p = argparse.ArgumentParser()
    p.add_argument("truth")
    p.add_argument("--frames", default="0:37:4")
    p.add_argument("--planes", default="reslice")
    p.add_argument("--labels", default=None)
    p.add_argument("--model", default="warp", choices=["point", "warp"])
    p.add_argument("--steps", type=int, default=1000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--shape-band", type=float, default=1.0)
    p.add_argument("--motion-factor", type=float, default=0.5)
    p.add_argument("--motion-omega", type=float, default=5.0)
    p.add_argument("--motion-width", type=int, default=64)
    p.add_argument("--width", type=int, default=256)
    p.add_argument("--depth", type=int, default=4)
    p.add_argument("--batch", type=int, default=1024)
    p.add_argument("--lambda-jacobian", type=float, default=0.01)
    p.add_argument("--motion-lr", type=float, default=1e-3)
    p.add_argument("--eikonal", default="canonical", choices=["canonical", "world"])
    p.add_argument("--score-every", type=int, default=1)
    args = p.parse_args()
    torch.manual_seed(args.seed)
    rng = np.random.default_rng(args.seed)
    torch.set_num_threads(2)

    img = nib.load(args.truth)
    data = np.asarray(img.dataobj).astype(np.int16)
    n_frames = data.shape[3]
    frames = parse_frames(args.frames, n_frames)
    labels = [int(v) for v in args.labels.split(",")] if args.labels else sorted(
        int(v) for v in np.unique(data) if v)
    k = len(labels)
    vox_affine = np.diag(list(np.sqrt((img.affine[:3, :3] ** 2).sum(0))) + [1.0])
    per_frame, lo, hi, vox, pixel = build_data(data, frames, labels, args.planes, vox_affine)
    centre = 0.5 * (lo + hi) * vox
    scale = 1.0 / (0.5 * ((hi - lo + 4) * vox).max() * 1.1)
    tn = lambda f: 2.0 * f / (n_frames - 1) - 1.0  # noqa: E731
    dt = 2.0 * (frames[1] - frames[0]) / (n_frames - 1)

    # Per frame tensors (normalised).
    frame_pts, frame_sdf, frame_contour = [], [], []
    for pts, sdf in per_frame:
        frame_pts.append(torch.tensor((pts - centre) * scale, dtype=torch.float32))
        frame_sdf.append(torch.tensor(sdf * scale, dtype=torch.float32))
        frame_contour.append([np.flatnonzero(np.abs(sdf[:, c]) <= 0.5 * pixel) for c in range(k)])
    near = [[np.flatnonzero(np.abs(sdf[:, c]) <= 10.0) for c in range(k)] for _, sdf in per_frame]

    model = Model(args, k, dt)
    groups = [{"params": model.g.parameters(), "lr": 1e-3}]
    if args.model == "warp":
        groups.append({"params": model.u.parameters(), "lr": args.motion_lr})
    opt = torch.optim.Adam(groups)
    base_lrs = [g["lr"] for g in opt.param_groups]
    n = args.batch
    t0 = time.time()
    for step in range(args.steps):
        frac = step / max(args.steps - 1, 1)
        for g, b in zip(opt.param_groups, base_lrs):
            g["lr"] = b * (0.1 + 0.9 * 0.5 * (1 + math.cos(math.pi * frac)))
        loss = 0.0
        for c in range(k):
            fi = rng.integers(len(frames), size=n)
            # Contour points and plane samples (half near the contour), per frame drawn.
            cx, ct, px, pt, ps = [], [], [], [], []
            for j in np.unique(fi):
                m = int((fi == j).sum())
                cidx = frame_contour[j][c]
                if len(cidx):
                    sel = cidx[rng.integers(len(cidx), size=m)]
                    cx.append(frame_pts[j][sel])
                    ct.append(torch.full((m,), tn(frames[j])))
                half = m // 2
                sel = np.concatenate([rng.integers(len(frame_pts[j]), size=m - half),
                                      near[j][c][rng.integers(max(len(near[j][c]), 1), size=half)]
                                      if len(near[j][c]) else rng.integers(len(frame_pts[j]), size=half)])
                px.append(frame_pts[j][sel])
                pt.append(torch.full((m,), tn(frames[j])))
                ps.append(frame_sdf[j][sel, c])
            if cx:
                fc = model(torch.cat(cx), torch.cat(ct))[:, c]
                loss = loss + fc.abs().mean()
            fp = model(torch.cat(px), torch.cat(pt))[:, c]
            target = torch.cat(ps)
            absent = target > 1.0
            term = torch.where(absent, torch.relu(0.05 - fp) ** 2, (fp - target) ** 2)
            loss = loss + 0.1 * term.mean()
        # Space-time samples: the eikonal and the minimum-surface term.
        xs = torch.rand(n, 3) * 2 - 1
        ts = torch.rand(n) * 2 - 1
        if args.model == "warp" and args.eikonal == "canonical":
            y = model.warp(xs, ts).detach().requires_grad_(True)
            fs = model.g(y, ts)
            grads = [torch.autograd.grad(fs[:, c].sum(), y, create_graph=True)[0] for c in range(k)]
            fw = model(xs, ts)  # the minimum-surface term on the world field
        else:
            xs.requires_grad_(True)
            fs = model(xs, ts)
            grads = [torch.autograd.grad(fs[:, c].sum(), xs, create_graph=True)[0] for c in range(k)]
            fw = fs
        reg = 0.0
        for c in range(k):
            reg = reg + ((grads[c].norm(dim=1) - 1) ** 2).mean() + torch.exp(-50 * fw[:, c].abs()).mean()
        loss = loss + 0.2 * reg
        if args.model == "warp":
            xj = (torch.rand(n // 2, 3) * 2 - 1).requires_grad_(True)
            tj = torch.rand(n // 2) * 2 - 1
            u = model.u(xj, tj)
            jac = torch.stack([torch.autograd.grad(u[:, i].sum(), xj, create_graph=True)[0]
                               for i in range(3)], 1)
            det = torch.det(torch.eye(3) + jac)
            loss = loss + args.lambda_jacobian * (jac ** 2).sum((1, 2)).mean() \
                + torch.relu(0.2 - det).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        model.project()
    train_s = time.time() - t0

    # Score on the truth's grid, every frame.
    idx = np.indices(data.shape[:3]).reshape(3, -1).T
    box = ((idx >= lo - 8) & (idx <= hi + 8)).all(1)
    pts = torch.tensor((idx[box] * vox - centre) * scale, dtype=torch.float32)
    inter = np.zeros((k, n_frames))
    union = np.zeros((k, n_frames))
    vol_p = np.zeros((k, n_frames))
    vol_t = np.zeros((k, n_frames))
    cen_p = np.zeros((k, n_frames, 3))
    cen_t = np.zeros((k, n_frames, 3))
    scored = list(range(0, n_frames, args.score_every))
    with torch.no_grad():
        for f in scored:
            out = []
            for chunk in torch.split(pts, 65536):
                out.append(model(chunk, torch.full((len(chunk),), tn(f))))
            fv = torch.cat(out).numpy()
            lab = np.where(fv.min(1) < 0, fv.argmin(1) + 1, 0)
            truth = data[..., f].reshape(-1)[box]
            for c, l in enumerate(labels):
                pm, tm = lab == c + 1, truth == l
                inter[c, f] = (pm & tm).sum()
                union[c, f] = (pm | tm).sum()
                vol_p[c, f], vol_t[c, f] = pm.sum(), tm.sum()
                if pm.any():
                    cen_p[c, f] = idx[box][pm].mean(0) * vox
                cen_t[c, f] = idx[box][tm].mean(0) * vox
    result = {"model": args.model, "steps": args.steps, "seed": args.seed, "train_s": round(train_s, 1)}
    for c, l in enumerate(labels):
        per = inter[c, scored] / np.maximum(union[c, scored], 1)
        ratio = vol_p[c, scored] / np.maximum(vol_t[c, scored], 1)
        result[str(l)] = {
            "iou": round(float(inter[c].sum() / union[c].sum()), 4),
            "iou_trained": round(float(inter[c, frames].sum() / union[c, frames].sum()), 4),
            "iou_min": round(float(per.min()), 3), "iou_min_frame": scored[int(per.argmin())],
            "volume_ratio_range": [round(float(ratio.min()), 3), round(float(ratio.max()), 3)],
            "travel_mm": [round(float(np.ptp(cen_p[c, scored, a])), 2) for a in range(3)],
            "travel_true_mm": [round(float(np.ptp(cen_t[c, scored, a])), 2) for a in range(3)],
        }
    print(json.dumps(result))


if __name__ == "__main__":
    main()
