#!/usr/bin/env python3
"""DynaSlice's training step written the way a PyTorch user would: the reference for
`dynaslice-lab torch-step` (lab/src/experiments/torch_step.rs).

The network and loss are exactly the trainer's (dynaslice-train: network.rs, loss.rs,
objective.rs, temporal_bound.rs; the paper's Eq. 1-10):

- f = L . S^d . ... . S^0 with S^i(y) = sin(W^i y + b^i) (Eq. 1), omega_0 folded into the
  weights; the first layer is sin(omega_x x + omega_t t + phi) with omega_x and omega_t separate
  parameters (Eq. 2), omega_t clamped to [-omega_t_max, omega_t_max] after every Adam step (Eq. 4);
  K output channels, one per class.
- Per class k, on its own samples (Eq. 10):
  contour points |f_k| + lambda_n ReLU(<-grad_x f_k, n>) (Eq. 5, 6);
  plane samples lambda_d (f_k - target)^2, or lambda_d ReLU(b - f_k)^2 where class k is annotated
  on the plane but absent from it (Eq. 7);
  space-time samples, every channel: lambda_r [(|grad_x f_k| - 1)^2 + exp(-alpha |f_k|)] (Eq. 8).
  Each sample carries its weight (1/N_k: per-class means), as the trainer's samplers set it.
- grad_x by torch.autograd.grad(..., create_graph=True), then loss.backward(), then Adam.

Commands (JSON on stdout):
  step.py time --classes K --contour N[,N...] --plane N[,N...] --space N [--widths 256,256,256,256]
          [--threads T] [--repeats R] [--warmup W] [--grad loop|batched]
      median seconds per step (loss, gradient, Adam) over R steps after W, on a random batch
      of these sizes (per class, or one count for every class).
  step.py check FILE
      FILE (written by `dynaslice-lab torch-step`): parameters in the core's order, a batch, the
      loss weights and the Rust trainer's loss terms and parameter gradient. Recomputes them here
      and exits 3 when they disagree beyond the tolerances (2 on unusable input).
"""

import argparse
import json
import math
import statistics
import sys
import time

import torch

INPUT_DIM = 4
# Largest sizes accepted (memory is bounded before anything is allocated): the trainer's own
# limits are of this order (dynaslice-core format MAX_WIDTH, MAX_CLASSES).
MAX_WIDTH = 4096
MAX_LAYERS = 16
MAX_CLASSES = 255
MAX_POINTS = 1 << 22
# Agreement tolerances of `check`: float32 sums in a different order than the trainer's. Measured
# agreement at widths 256x4, K = 1..41: loss terms within 3e-7, gradient within 1.1e-6 (relative L2).
TERM_RTOL = 1e-5
GRAD_RTOL = 1e-4
# Exit status of `check` on disagreement (1 is Python's own for an uncaught error, 2 argparse's).
DISAGREE = 3


class Siren(torch.nn.Module):
    """Eq. 1-2: sine layers with omega_0 folded into the weights, an affine output layer."""

    def __init__(self, widths, classes, omega_0=30.0, omega_t_max=math.inf):
        super().__init__()
        w0 = widths[0]
        # First layer, Eq. 2: separate spatial and temporal frequencies and a phase.
        self.omega_x = torch.nn.Parameter(torch.empty(w0, 3))
        self.omega_t = torch.nn.Parameter(torch.empty(w0))
        self.phi = torch.nn.Parameter(torch.empty(w0))
        dims = list(widths) + [classes]
        self.layers = torch.nn.ModuleList(
            torch.nn.Linear(dims[i], dims[i + 1]) for i in range(len(widths))
        )
        self.siren_init(omega_0, omega_t_max)

    @torch.no_grad()
    def siren_init(self, omega_0, omega_t_max):
        """SIREN's initialisation with omega_0 folded in, omega_t drawn inside the temporal
        bound (as dynaslice-train network.rs)."""
        bound = omega_0 / INPUT_DIM
        self.omega_x.uniform_(-bound, bound)
        bound_t = min(bound, omega_t_max)
        self.omega_t.uniform_(-bound_t, bound_t)
        self.phi.uniform_(-omega_0 / math.sqrt(INPUT_DIM), omega_0 / math.sqrt(INPUT_DIM))
        for i, layer in enumerate(self.layers):
            fan_in = layer.in_features
            bound = math.sqrt(6.0 / fan_in)
            is_output = i + 1 == len(self.layers)
            if is_output:
                bound /= omega_0
            layer.weight.uniform_(-bound, bound)
            b = (1.0 if is_output else omega_0) / math.sqrt(fan_in)
            layer.bias.uniform_(-b, b)

    def forward(self, x, t):
        """f at points x (N x 3) and times t (N): N x K."""
        h = torch.sin(x @ self.omega_x.T + t[:, None] * self.omega_t + self.phi)
        for layer in self.layers[:-1]:
            h = torch.sin(layer(h))
        return self.layers[-1](h)

    def core_order(self):
        """The parameters as the core stores them: per layer W^T (fan_in x fan_out), then b."""
        first = [torch.cat([self.omega_x.T, self.omega_t[None, :]]), self.phi]
        rest = [p for layer in self.layers for p in (layer.weight.T, layer.bias)]
        return first + rest

    @torch.no_grad()
    def load_core(self, flat):
        """Sets the parameters from a flat vector in the core's order."""
        flat = torch.as_tensor(flat, dtype=torch.float32)
        if flat.numel() != self.param_count():
            raise ValueError(f"{flat.numel()} parameters, the layout has {self.param_count()}")
        offset = 0

        def take(n):
            nonlocal offset
            v = flat[offset : offset + n]
            offset += n
            return v

        w0 = self.phi.shape[0]
        wt0 = take(INPUT_DIM * w0).reshape(INPUT_DIM, w0)
        self.omega_x.copy_(wt0[:3].T)
        self.omega_t.copy_(wt0[3])
        self.phi.copy_(take(w0))
        for layer in self.layers:
            fan_in, fan_out = layer.in_features, layer.out_features
            layer.weight.copy_(take(fan_in * fan_out).reshape(fan_in, fan_out).T)
            layer.bias.copy_(take(fan_out))

    def core_gradient(self):
        """The parameters' .grad flattened in the core's order."""
        first = [
            torch.cat([self.omega_x.grad.T, self.omega_t.grad[None, :]]),
            self.phi.grad,
        ]
        rest = [p for layer in self.layers for p in (layer.weight.grad.T, layer.bias.grad)]
        return torch.cat([g.reshape(-1) for g in first + rest])

    def param_count(self):
        return sum(p.numel() for p in self.parameters())


def spatial_gradients(f, x, mode):
    """grad_x f_k for every channel k of f (N x K) at x (N x 3): K x N x 3, kept differentiable."""
    k = f.shape[1]
    if mode == "batched" and k > 1:
        # One vmapped backward for all channels (autograd.grad's is_grads_batched).
        eye = torch.eye(k, dtype=f.dtype)[:, None, :].expand(k, f.shape[0], k)
        return torch.autograd.grad(f, x, grad_outputs=eye, create_graph=True, is_grads_batched=True)[0]
    # One backward per channel.
    return torch.stack(
        [torch.autograd.grad(f[:, c].sum(), x, create_graph=True)[0] for c in range(k)]
    )


def loss_terms(model, batch, weights, mode):
    """The five sums of the DynaSlice loss (dynaslice-train loss.rs LossTerms) and the total."""
    lam_n, lam_d, lam_r, alpha = (
        weights["orientation"],
        weights["plane"],
        weights["regulariser"],
        weights["alpha"],
    )
    # Contour points: f of their own class and its derivative along their normal (Eq. 5, 6).
    # The points are independent, so one backward of the sum gives every point's own gradient.
    xc = batch["contour_x"][:, :3].clone().requires_grad_(True)
    fc = model(xc, batch["contour_x"][:, 3])
    f_own = fc.gather(1, batch["contour_class"][:, None])[:, 0]
    (gc,) = torch.autograd.grad(f_own.sum(), xc, create_graph=True)
    dn = (gc * batch["contour_normal"]).sum(1)
    wc = batch["contour_weight"]
    surface = (wc * f_own.abs()).sum()
    orientation = (wc * torch.relu(-dn)).sum()

    # Plane samples (Eq. 7): f - target, only its negative part where the class is absent.
    fp = model(batch["plane_x"][:, :3], batch["plane_x"][:, 3])
    r = fp.gather(1, batch["plane_class"][:, None])[:, 0] - batch["plane_target"]
    r = torch.where(batch["plane_absent"], r.clamp(max=0.0), r)
    plane = (batch["plane_weight"] * r * r).sum()

    # Space-time samples, every channel (Eq. 8): means over the samples, summed over classes.
    xs = batch["space_x"][:, :3].clone().requires_grad_(True)
    fs = model(xs, batch["space_x"][:, 3])
    gs = spatial_gradients(fs, xs, mode)  # K x N x 3
    eikonal = ((gs.norm(dim=2) - 1.0) ** 2).mean(1).sum()
    spurious = torch.exp(-alpha * fs.abs()).mean(0).sum()

    total = surface + lam_n * orientation + lam_d * plane + lam_r * (eikonal + spurious)
    return {
        "surface": surface,
        "orientation": orientation,
        "plane": plane,
        "eikonal": eikonal,
        "spurious": spurious,
        "total": total,
    }


def random_batch(contour, plane, space, gen):
    """The benchmark's batch (dynaslice-train bench.rs random_batch): contour[k] contour points
    and plane[k] plane samples of class k, each weighing 1/count (per-class means, Eq. 10),
    and `space` space-time samples, all uniform in [-1, 1]^3 x [0, 1]."""

    def points(n):
        p = torch.rand(n, INPUT_DIM, generator=gen)
        p[:, :3] = 2.0 * p[:, :3] - 1.0
        return p

    def classes(counts):
        c = torch.tensor(counts)
        cls = torch.arange(len(counts)).repeat_interleave(c)
        return cls, (1.0 / c.to(torch.float32)).repeat_interleave(c)

    cc, wc = classes(contour)
    pc, wp = classes(plane)
    return {
        "contour_x": points(len(cc)),
        "contour_normal": torch.tensor([1.0, 0.0, 0.0]).expand(len(cc), 3).contiguous(),
        "contour_class": cc,
        "contour_weight": wc,
        "plane_x": points(len(pc)),
        "plane_class": pc,
        "plane_target": torch.full((len(pc),), 0.1),
        "plane_absent": torch.zeros(len(pc), dtype=torch.bool),
        "plane_weight": wp,
        "space_x": points(space),
    }


def per_class_counts(text, k, name):
    """N (the same for every class) or one count per class."""
    try:
        counts = [int(v) for v in text.split(",")]
    except ValueError:
        raise SystemExit(f"--{name} {text}: whole numbers expected")
    if len(counts) == 1:
        counts *= k
    if len(counts) != k or not all(1 <= n <= MAX_POINTS for n in counts):
        raise SystemExit(f"--{name}: one count, or {k} counts, each in 1..={MAX_POINTS}")
    if sum(counts) > MAX_POINTS:
        raise SystemExit(f"--{name}: more than {MAX_POINTS} samples in all")
    return counts


def positive_int(limit):
    def parse(s):
        v = int(s)
        if not 1 <= v <= limit:
            raise argparse.ArgumentTypeError(f"{v} is not in 1..={limit}")
        return v

    return parse


def sgemm_gflops(repeats):
    """PyTorch's own 1024^3 float32 product on the current threads (median GFLOP/s)."""
    n = 1024
    a = torch.rand(n, n)
    b = torch.rand(n, n)
    a @ b
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        a @ b
        times.append(time.perf_counter() - start)
    return 2.0 * n**3 / statistics.median(times) / 1e9


def time_command(args):
    widths = [int(w) for w in args.widths.split(",")]
    if not 1 <= len(widths) <= MAX_LAYERS or not all(1 <= w <= MAX_WIDTH for w in widths):
        raise SystemExit(f"--widths {args.widths}: 1 to {MAX_LAYERS} widths of 1 to {MAX_WIDTH}")
    contour = per_class_counts(args.contour, args.classes, "contour")
    plane = per_class_counts(args.plane, args.classes, "plane")
    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    gen = torch.Generator().manual_seed(args.seed)
    model = Siren(widths, args.classes, omega_t_max=args.omega_t_max)
    opt = torch.optim.Adam(model.parameters(), lr=1e-3, betas=(0.9, 0.999), eps=1e-8)
    batch = random_batch(contour, plane, args.space, gen)
    weights = DEFAULT_WEIGHTS

    def step():
        opt.zero_grad(set_to_none=True)
        loss = loss_terms(model, batch, weights, args.grad)["total"]
        loss.backward()
        opt.step()
        with torch.no_grad():
            model.omega_t.clamp_(-args.omega_t_max, args.omega_t_max)
        return loss

    for _ in range(args.warmup):
        step()
    times = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        step()
        times.append(time.perf_counter() - start)
    json.dump(
        {
            "classes": args.classes,
            "widths": widths,
            "contour": contour,
            "plane": plane,
            "space": args.space,
            "threads": torch.get_num_threads(),
            "grad": args.grad,
            "params": model.param_count(),
            "seconds": statistics.median(times),
            "times": times,
            "sgemm_gflops": sgemm_gflops(5),
            "torch": torch.__version__,
        },
        sys.stdout,
    )
    print()


# TrainOptions::default().loss (dynaslice-train trainer.rs).
DEFAULT_WEIGHTS = {"orientation": 0.1, "plane": 0.1, "regulariser": 0.2, "alpha": 50.0}


def relative(a, b):
    return abs(a - b) / max(abs(b), 1e-30)


def check_command(args):
    try:
        with open(args.file) as f:
            spec = json.load(f)
        widths = [int(w) for w in spec["widths"]]
        k = int(spec["classes"])
        if not 1 <= len(widths) <= MAX_LAYERS or not all(1 <= w <= MAX_WIDTH for w in widths):
            raise ValueError(f"widths {widths}")
        if not 1 <= k <= MAX_CLASSES:
            raise ValueError(f"{k} classes")
        model = Siren(widths, k)
        model.load_core(spec["params"])
        b = spec["batch"]
        f32 = lambda v, *shape: torch.tensor(v, dtype=torch.float32).reshape(*shape)
        idx = lambda v: torch.tensor(v, dtype=torch.int64).reshape(-1)
        batch = {
            "contour_x": f32(b["contour_x"], -1, INPUT_DIM),
            "contour_normal": f32(b["contour_normal"], -1, 3),
            "contour_class": idx(b["contour_class"]),
            "contour_weight": f32(b["contour_weight"], -1),
            "plane_x": f32(b["plane_x"], -1, INPUT_DIM),
            "plane_class": idx(b["plane_class"]),
            "plane_target": f32(b["plane_target"], -1),
            "plane_absent": torch.tensor(b["plane_absent"], dtype=torch.bool).reshape(-1),
            "plane_weight": f32(b["plane_weight"], -1),
            "space_x": f32(b["space_x"], -1, INPUT_DIM),
        }
        for s in ("contour", "plane"):
            n = batch[f"{s}_x"].shape[0]
            for key, v in batch.items():
                if key.startswith(s) and v.shape[0] != n:
                    raise ValueError(f"{key} has {v.shape[0]} rows, {s}_x {n}")
            cls = batch[f"{s}_class"]
            if n and (cls.min() < 0 or cls.max() >= k):
                raise ValueError(f"{s} class outside 0..{k}")
        if batch["space_x"].shape[0] == 0:
            raise ValueError("no space-time samples")
        expected = spec["expected"]
        expected_terms = {name: float(v) for name, v in expected["terms"].items()}
        expected_grad = f32(expected["gradient"], -1)
        if expected_grad.numel() != model.param_count():
            raise ValueError(f"gradient of {expected_grad.numel()} values")
        weights = {name: float(spec["weights"][name]) for name in DEFAULT_WEIGHTS}
    except (OSError, KeyError, TypeError, ValueError, RuntimeError) as e:
        print(f"error: {args.file}: {e!r}", file=sys.stderr)
        raise SystemExit(2)

    model.zero_grad(set_to_none=True)
    terms = loss_terms(model, batch, weights, args.grad)
    terms["total"].backward()
    grad = model.core_gradient()
    got = {name: float(v.detach()) for name, v in terms.items()}
    errors = {name: relative(got[name], expected_terms[name]) for name in expected_terms}
    grad_error = float((grad - expected_grad).norm() / expected_grad.norm().clamp(min=1e-30))
    agree = all(e <= TERM_RTOL for e in errors.values()) and grad_error <= GRAD_RTOL
    json.dump(
        {
            "agree": agree,
            "terms": got,
            "relative_errors": errors,
            "gradient_relative_l2": grad_error,
            "tolerances": {"terms": TERM_RTOL, "gradient": GRAD_RTOL},
            "torch": torch.__version__,
        },
        sys.stdout,
    )
    print()
    if not agree:
        raise SystemExit(DISAGREE)


def main():
    torch.set_flush_denormal(True)
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    grad_help = "space-time gradients: one backward per channel (loop) or one vmapped backward (batched)"
    t = sub.add_parser("time", help="median seconds per training step on a random batch")
    t.add_argument("--classes", type=positive_int(MAX_CLASSES), required=True)
    t.add_argument("--contour", required=True, help="contour points per class: N, or N1,N2,... (one per class)")
    t.add_argument("--plane", required=True, help="plane samples per class: N, or N1,N2,...")
    t.add_argument("--space", type=positive_int(MAX_POINTS), required=True)
    t.add_argument("--widths", default="256,256,256,256")
    t.add_argument("--threads", type=positive_int(1024), default=1)
    t.add_argument("--repeats", type=positive_int(1000), default=5)
    t.add_argument("--warmup", type=int, default=1)
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--omega-t-max", type=float, default=10.0)
    t.add_argument("--grad", choices=["loop", "batched"], default="loop", help=grad_help)
    c = sub.add_parser("check", help="compare the loss and gradient with the trainer's")
    c.add_argument("file")
    c.add_argument("--threads", type=positive_int(1024), default=1)
    c.add_argument("--grad", choices=["loop", "batched"], default="loop", help=grad_help)
    args = parser.parse_args()
    if args.command == "time":
        time_command(args)
    else:
        torch.set_num_threads(args.threads)
        check_command(args)


if __name__ == "__main__":
    main()
