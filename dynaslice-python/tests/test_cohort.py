"""examples/cohort_ray.py on a local Ray instance (2 CPUs), two tiny sequences."""

import csv
import os
import subprocess
import sys

import pytest

from conftest import ROOT, write_sphere_sections


def test_cohort_example_on_local_ray(tmp_path):
    try:
        import ray  # noqa: F401
    except ImportError:
        if os.environ.get("DYNASLICE_REQUIRE_RAY") == "1":
            raise
        pytest.skip("Ray is not installed (pip install ray): the cohort example is untested")
    a = write_sphere_sections(tmp_path / "a.json", frames=3, planes=5)
    b = write_sphere_sections(tmp_path / "b.json", frames=2, planes=7)
    out = tmp_path / "cohort"
    cmd = [sys.executable, str(ROOT / "examples" / "cohort_ray.py"), "--out", str(out),
           "--steps", "150", "--frames", "3", "--resolution", "24", "--num-cpus", "2",
           "--cpus-per-task", "1", "s1=%s" % a, "s2=%s" % b]
    subprocess.run(cmd, check=True, timeout=600, env=dict(os.environ, RAY_USAGE_STATS_ENABLED="0"))
    with open(out / "cohort.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["subject"], r["class"], r["label"]) for r in rows] == [
        ("s1", "ball", "3"), ("s1", "moon", "7"), ("s2", "ball", "3"), ("s2", "moon", "7")]
    for r in rows:
        assert r["steps"] == "150" and float(r["final_loss"]) > 0
        assert (out / r["subject"] / "model.dsm").exists()
        assert 0 <= float(r["volume_min"]) <= float(r["volume_max"])
