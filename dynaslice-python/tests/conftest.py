"""Shared fixtures: a small random model on disk, the workspace's built `dynaslice` binary and
C library when present, and a tiny training input written here."""

import json
import math
import os
import pathlib

import numpy as np
import pytest

import dynaslice

ROOT = pathlib.Path(__file__).resolve().parents[2]


def built(env, *names):
    """The first existing of $env, then ROOT/target/{release,debug}/<name>; None if none."""
    if os.environ.get(env):
        return pathlib.Path(os.environ[env])
    for profile in ("release", "debug"):
        for name in names:
            p = ROOT / "target" / profile / name
            if p.exists():
                return p
    return None


@pytest.fixture(scope="session")
def model():
    """A random 2-class SIREN (untrained weights have surfaces at irregular places)."""
    return dynaslice.random_model([32, 32], 2, seed=7)


@pytest.fixture(scope="session")
def model_path(model, tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "random.dsm"
    model.save(path)
    return path


def points_in(model, n, seed=0, dtype=np.float32):
    lo, hi = (np.array(b, dtype=np.float64) for b in model.bounds)
    rng = np.random.default_rng(seed)
    return (lo + (hi - lo) * rng.random((n, 3))).astype(dtype)


def write_sphere_sections(path, frames=3, planes=5):
    """Native JSON cross-sections of a ball of radius 0.35 + 0.1·t about the origin (world
    units; colour (200, 30, 60)), with a second class, a small ball at x = 0.7 of radius 0.2
    (no colour), cut by z-planes at `frames` times in [0, 1]."""
    def circle(cx, cy, r, n=48):
        return [[cx + r * math.cos(2 * math.pi * i / n), cy + r * math.sin(2 * math.pi * i / n)]
                for i in range(n)]

    out = {"format": "dynaslice-sections", "version": 1,
           "classes": [{"name": "ball", "label": 3, "color": [200, 30, 60]},
                       {"name": "moon", "label": 7}],
           "frames": []}
    for f in range(frames):
        t = f / max(frames - 1, 1)
        r = 0.35 + 0.1 * t
        plane_list = []
        for j in range(planes):
            z = -0.8 + 1.6 * j / max(planes - 1, 1)
            annotations = []
            big = r * r - z * z
            annotations.append({"class": 0, "polygons": [circle(0.0, 0.0, math.sqrt(big))] if big > 0.01 else []})
            small = 0.04 - z * z
            annotations.append({"class": 1, "polygons": [circle(0.7, 0.0, math.sqrt(small))] if small > 0.004 else []})
            plane_list.append({"origin": [0.0, 0.0, z], "u": [1.0, 0.0, 0.0], "v": [0.0, 1.0, 0.0],
                               "roi": {"min": [-1.0, -1.0], "max": [1.0, 1.0]},
                               "annotations": annotations})
        out["frames"].append({"time": t, "planes": plane_list})
    pathlib.Path(path).write_text(json.dumps(out))
    return path
