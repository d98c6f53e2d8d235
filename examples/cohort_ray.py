"""Train, mesh and score a cohort of sequences with Ray: one task per sequence.

Each task trains a model on its subject's cross-sections (``dynaslice.train``, on as many threads
as the task was given CPUs), meshes every class at ``--frames`` times over the model's time
range and records each class's enclosed volume over time. The driver gathers one row per
(subject, class) into a CSV table:

    subject,class,label,steps,final_loss,volume_min,volume_max,t_at_min,t_at_max,ejection_fraction,model

Run on a laptop (a local Ray instance) or a cluster (``ray start`` on the nodes, then
``--address auto``)::

    python examples/cohort_ray.py --out cohort/ subj01=data/s01.json subj02=data/s02/short.nii.gz

Each argument is ``SUBJECT=INPUT[+INPUT...]`` (several inputs: views of one subject). Ray
schedules the tasks; nothing here queues or retries work itself. Without Ray, the same per-subject
work runs through ``dynaslice train`` in a Slurm job array: examples/slurm/.
"""

import argparse
import csv
import os
import pathlib
import sys


def enclosed_volume(vertices, faces):
    """Volume inside a closed, outward-oriented triangle mesh (divergence theorem)."""
    import numpy as np

    v = vertices.astype(np.float64)
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def process(subject, inputs, out_dir, steps, frames, resolution, threads, seed):
    """Trains one subject's model, meshes it at `frames` times and returns its table rows."""
    import numpy as np

    import dynaslice

    out = pathlib.Path(out_dir) / subject
    out.mkdir(parents=True, exist_ok=True)
    losses = []
    model = dynaslice.train(inputs, out / "model.dsm", steps=steps, seed=seed,
                            threads=threads, progress=losses.append)
    t0, t1 = model.time_range
    times = np.linspace(t0, t1, frames) if frames > 1 else np.array([t0])
    volumes = np.zeros((len(times), model.num_classes))
    for i, t in enumerate(times):
        for k, mesh in enumerate(model.mesh(float(t), resolution=resolution, threads=threads)):
            volumes[i, k] = enclosed_volume(mesh.vertices, mesh.faces)
            np.savez_compressed(out / ("%s_t%03d.npz" % (mesh.name, i)), vertices=mesh.vertices,
                                faces=mesh.faces, normal_velocity=mesh.normal_velocity)
    rows = []
    for k, (name, label, _) in enumerate(model.classes):
        v = volumes[:, k]
        lo, hi = int(v.argmin()), int(v.argmax())
        rows.append({
            "subject": subject, "class": name, "label": label,
            "steps": losses[-1]["step"] if losses else 0,
            "final_loss": "%.6g" % losses[-1]["loss"] if losses else "",
            "volume_min": "%.6g" % v[lo], "volume_max": "%.6g" % v[hi],
            "t_at_min": "%.6g" % times[lo], "t_at_max": "%.6g" % times[hi],
            "ejection_fraction": "%.4f" % ((v[hi] - v[lo]) / v[hi]) if v[hi] > 0 else "",
            "model": str(out / "model.dsm"),
        })
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("subjects", nargs="+", metavar="SUBJECT=INPUT[+INPUT...]")
    ap.add_argument("--out", required=True, help="output folder (models, meshes, cohort.csv)")
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--frames", type=int, default=10, help="mesh times over each time range")
    ap.add_argument("--resolution", type=int, default=96)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cpus-per-task", type=int, default=2, help="Ray CPUs (= threads) per subject")
    ap.add_argument("--address", default=None, help="Ray cluster address (default: start locally)")
    ap.add_argument("--num-cpus", type=int, default=None, help="CPUs of a local Ray instance")
    a = ap.parse_args(argv)

    jobs = []
    for spec in a.subjects:
        subject, sep, inputs = spec.partition("=")
        if not sep or not subject or not inputs:
            ap.error("%r is not SUBJECT=INPUT[+INPUT...]" % spec)
        jobs.append((subject, [os.path.abspath(p) for p in inputs.split("+")]))
    if len({s for s, _ in jobs}) != len(jobs):
        ap.error("subject names must be unique")

    import ray

    ray.init(address=a.address, num_cpus=a.num_cpus if a.address is None else None,
             include_dashboard=False, log_to_driver=True)
    task = ray.remote(num_cpus=a.cpus_per_task)(process)
    out_dir = os.path.abspath(a.out)
    futures = [task.remote(s, inputs, out_dir, a.steps, a.frames, a.resolution,
                           a.cpus_per_task, a.seed) for s, inputs in jobs]
    rows = [row for result in ray.get(futures) for row in result]
    ray.shutdown()

    table = pathlib.Path(out_dir) / "cohort.csv"
    with open(table, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print("wrote %s: %d rows for %d subjects" % (table, len(rows), len(jobs)), file=sys.stderr)
    return table


if __name__ == "__main__":
    main()
