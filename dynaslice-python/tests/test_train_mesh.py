"""Training from Python, meshing and label volumes."""

import _thread
import signal
import threading

import numpy as np
import pytest

import dynaslice
from conftest import points_in, write_sphere_sections

SMALL = dict(widths=[32, 32], contour_samples=256, plane_samples=256, space_samples=256)


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    d = tmp_path_factory.mktemp("train")
    sections = write_sphere_sections(d / "spheres.json")
    seen = []
    model = dynaslice.train(sections, d / "spheres.dsm", steps=1500, seed=1, threads=2,
                            progress=seen.append, **SMALL)
    return model, d, seen


def test_training_writes_a_model_that_learnt_the_spheres(trained):
    model, d, seen = trained
    # The model and its loss log; a finished run leaves no checkpoint behind.
    assert (d / "spheres.dsm").exists() and (d / "spheres.dsm.loss.csv").exists()
    assert not (d / "spheres.dsm.ckpt").exists()
    assert dynaslice.Model.load(d / "spheres.dsm").to_bytes() == model.to_bytes()
    assert model.classes == [("ball", 3, (200, 30, 60)), ("moon", 7, None)]
    # The input's colour where it gave one, else the palette's second colour (Tableau 10).
    assert model.class_colors == [(200, 30, 60), (0xFF, 0x7F, 0x0E)]
    assert model.time_range == pytest.approx((0.0, 1.0))
    assert "steps = 1500" in model.metadata
    # Progress: increasing steps, the last one reported, loss going down.
    steps = [p["step"] for p in seen]
    assert steps == sorted(steps) and steps[-1] == 1500 and seen[-1]["steps"] == 1500
    assert seen[-1]["loss"] < seen[0]["loss"]
    probe = np.array([[0.0, 0.0, 0.0], [0.7, 0.0, 0.0], [0.0, -0.8, 0.0]])
    assert list(model.labels(probe, 0.5)) == [3, 7, 0]


def test_mesh_of_the_trained_model(trained):
    model = trained[0]
    ball = model.mesh(0.5, cls="ball", resolution=48)
    assert isinstance(ball, dynaslice.Mesh) and ball.name == "ball" and ball.label == 3
    v, faces, vn = ball
    assert v.dtype == np.float32 and v.ndim == 2 and v.shape[1] == 3 and len(v) > 100
    assert faces.dtype == np.int64 and faces.shape[1] == 3 and faces.max() < len(v)
    assert vn.shape == (len(v),) and ball.normals.shape == v.shape
    # Sparse planes leave regions no data reaches, where the mesh may hold spurious parts:
    # look at the part around the ball. On the surface there (one Newton step), at the radius
    # 0.35 + 0.1·t, moving outwards at dr/dt = 0.1.
    radius = np.linalg.norm(v, axis=1)
    near = radius < 0.6
    assert near.sum() > 1000
    # One Newton step confined to its lattice edge (meshes cannot fold; docs/meshing.md):
    # nearly every vertex within 1e-3 of the zero level set, which the lattice edge's linear
    # interpolation alone misses (its 99th percentile is 2.4e-3 on this model, with the step
    # 2.8e-4), and none a quarter of the cell (0.042 here) away (the worst is 5.8e-3 with the
    # step, 3.8e-3 without: one step can overshoot on a curved edge).
    residual = np.abs(model.sdf(v[near], 0.5)[:, 0])
    assert np.percentile(residual, 99) < 1e-3 and residual.max() < 1e-2
    assert abs(np.median(radius[near]) - 0.40) < 0.02
    assert abs(np.median(vn[near]) - 0.1) < 0.03
    both = model.mesh(0.5, resolution=32)
    assert [m.name for m in both] == ["ball", "moon"]
    assert [m.name for m in model.mesh(0.5, cls=[2, "ball"], resolution=32)] == ["moon", "ball"]
    with pytest.raises(ValueError, match='no class "heart"; the model\'s classes are 1 "ball", 2 "moon"'):
        model.mesh(0.5, cls="heart")
    with pytest.raises(ValueError, match="outside the model's time range"):
        model.mesh(3.0)


def test_mesh_helpers(trained):
    ball = trained[0].mesh(0.5, cls=1, resolution=32)
    trimesh = pytest.importorskip("trimesh", reason="trimesh not installed: to_trimesh untested")
    assert ball.color == (200, 30, 60)
    tm = ball.to_trimesh()
    assert isinstance(tm, trimesh.Trimesh) and tm.is_watertight
    assert len(tm.vertices) == len(ball.vertices)
    assert (tm.visual.vertex_colors == [200, 30, 60, 255]).all()


def test_mesh_to_pyvista(trained):
    ball = trained[0].mesh(0.5, cls=1, resolution=32)
    pytest.importorskip("pyvista", reason="pyvista not installed: to_pyvista untested")
    poly = ball.to_pyvista()
    assert poly.n_points == len(ball.vertices) and poly.n_cells == len(ball.faces)
    np.testing.assert_array_equal(poly.point_data["normal_velocity"], ball.normal_velocity)
    assert (poly.point_data["Colors"] == [200, 30, 60]).all()


def test_label_volume_like_a_nibabel_image_and_a_file(trained, tmp_path):
    nib = pytest.importorskip("nibabel", reason="nibabel not installed: label volumes untested")
    model = trained[0]
    affine = np.array([[0.05, 0, 0, -0.9], [0, 0.05, 0, -0.9], [0, 0, 0.1, -0.5], [0, 0, 0, 1.0]])
    data = np.zeros((37, 36, 11, 3), dtype=np.int16)
    image = nib.Nifti1Image(data, affine)
    image.header.set_xyzt_units("mm", "sec")
    image.header["pixdim"][4] = 0.5
    ref = tmp_path / "ref.nii.gz"
    nib.save(image, ref)
    vol = model.label_volume(like=image)
    assert vol.shape == (37, 36, 11, 3) and vol.dtype == np.int32
    # Each voxel's label is the model's at its centre and its frame's time (f · 0.5).
    ijk = np.stack(np.meshgrid(*[np.arange(s) for s in (37, 36, 11)], indexing="ij"), -1).reshape(-1, 3)
    world = ijk @ affine[:3, :3].T + affine[:3, 3]
    for f in range(3):
        expected = model.labels(world, 0.5 * f).reshape(37, 36, 11)
        np.testing.assert_array_equal(vol[..., f], expected)
    assert set(np.unique(vol)) == {0, 3, 7}
    out = tmp_path / "labels.nii.gz"
    from_file = model.label_volume(like=ref, output=out)
    np.testing.assert_array_equal(from_file, vol)
    np.testing.assert_array_equal(np.asanyarray(nib.load(out).dataobj), vol)
    single = model.label_volume(like=ref, times=0.25)
    assert single.shape == (37, 36, 11)
    np.testing.assert_array_equal(single, model.labels(world, 0.25).reshape(37, 36, 11))
    with pytest.raises(dynaslice.DynasliceError, match="missing.nii"):
        model.label_volume(like=tmp_path / "missing.nii")


def test_train_errors_and_interrupts(tmp_path):
    sections = write_sphere_sections(tmp_path / "s.json", frames=2, planes=3)
    with pytest.raises(dynaslice.DynasliceError, match="nope.json"):
        dynaslice.train(tmp_path / "nope.json", tmp_path / "m.dsm", steps=1, progress=False)
    with pytest.raises(TypeError, match="unexpected keyword argument 'omega'"):
        dynaslice.train(sections, tmp_path / "m.dsm", steps=1, omega=3.0)

    # A callback's exception stops training at a checkpoint and propagates.
    class Stop(Exception):
        pass

    def stop_at_once(p):
        raise Stop("enough")

    out = tmp_path / "m.dsm"
    with pytest.raises(Stop, match="enough"):
        dynaslice.train(sections, out, steps=100_000, threads=1, progress=stop_at_once, **SMALL)
    assert (tmp_path / "m.dsm.ckpt").exists() and not out.exists()

    # Ctrl-C (SIGINT's flag, as the terminal sets it) stops, saves and raises. Python's own
    # SIGINT handler is installed for it: a process started with SIGINT ignored (a background
    # job, nohup, some CI runners) has none, and there an interrupt rightly does nothing.
    # A fresh start: the stopped run's state goes (kept, it would need resume=True or force=True).
    (tmp_path / "m.dsm.ckpt").unlink()
    (tmp_path / "m.dsm.ckpt.loss.csv").unlink()
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(1.0, _thread.interrupt_main)
    try:
        timer.start()
        with pytest.raises(KeyboardInterrupt, match="checkpoint .*m.dsm.ckpt saved"):
            dynaslice.train(sections, out, steps=100_000, threads=1, progress=False, **SMALL)
    finally:
        timer.join()
        signal.signal(signal.SIGINT, previous)
    assert (tmp_path / "m.dsm.ckpt").exists() and not out.exists()
    # ... and resume=True continues from there.
    first = []

    def record_and_stop(p):
        first.append(p["step"])
        raise Stop("seen")

    with pytest.raises(Stop):
        dynaslice.train(sections, out, steps=100_000, threads=1, progress=record_and_stop,
                        resume=True, **SMALL)
    assert first[0] > 1, "resumed at step %d" % first[0]


def test_train_replaces_nothing_without_force(tmp_path):
    sections = write_sphere_sections(tmp_path / "s.json", frames=2, planes=3)
    out = tmp_path / "m.dsm"
    out.write_bytes(b"a user's earlier model")
    with pytest.raises(dynaslice.DynasliceError, match=r"m\.dsm: the file exists .*add force=True"):
        dynaslice.train(sections, out, steps=2, threads=1, progress=False, **SMALL)
    assert out.read_bytes() == b"a user's earlier model"
    # The loss log beside it is an output too.
    out.unlink()
    (tmp_path / "m.dsm.loss.csv").write_text("kept\n")
    with pytest.raises(dynaslice.DynasliceError, match=r"m\.dsm\.loss\.csv: the file exists"):
        dynaslice.train(sections, out, steps=2, threads=1, progress=False, **SMALL)
    assert not out.exists() and (tmp_path / "m.dsm.loss.csv").read_text() == "kept\n"
    # The name says what is written.
    with pytest.raises(dynaslice.DynasliceError, match=r"a model must be named \*\.dsm"):
        dynaslice.train(sections, tmp_path / "m.json", steps=2, threads=1, progress=False,
                        force=True, **SMALL)
    model = dynaslice.train(sections, out, steps=2, threads=1, progress=False, force=True,
                            **SMALL)
    assert out.exists() and model.num_classes >= 1


def test_a_static_model_answers_any_time_at_its_one_time(tmp_path, caplog):
    # One timestep: a static model (ω_t^max = 0), the same at every time, as `dynaslice info`
    # says; Python answers any time there, as `dynaslice query`, `mesh` and `labels` do.
    sections = write_sphere_sections(tmp_path / "one.json", frames=1, planes=5)
    model = dynaslice.train(sections, tmp_path / "static.dsm", steps=40, seed=3, threads=1,
                            progress=False, **SMALL)
    assert model.is_static
    t0, t1 = model.time_range
    assert t0 == t1, "a static model has one time, not a range"
    assert "static" in repr(model)
    p = points_in(model, 500)
    at_t0 = model.sdf(p, t0)
    caplog.set_level("INFO")
    for t in (t0 + 7.0, -3.5, np.linspace(-10.0, 10.0, len(p))):
        np.testing.assert_array_equal(model.sdf(p, t), at_t0)
        np.testing.assert_array_equal(model.labels(p, t), model.labels(p, t0))
    assert any("static model" in r.getMessage() and "answering at its time" in r.getMessage()
               for r in caplog.records), [r.getMessage() for r in caplog.records]
    with pytest.raises(ValueError, match="not a finite number"):
        model.sdf(p, float("nan"))
    # Meshes and label volumes: once, at its time, whatever times are asked for.
    a, b = model.mesh(t0, cls="ball", resolution=24), model.mesh(t0 + 5.0, cls="ball", resolution=24)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    affine = np.diag([0.1, 0.1, 0.1, 1.0])
    affine[:3, 3] = -1.0

    class Image:
        shape = (20, 20, 20)
        header = None

    Image.affine = affine
    volume = model.label_volume(Image(), times=[0.0, 0.5, 9.0])
    assert volume.shape == (20, 20, 20, 1), "a static model's label volume has one frame"
    assert set(np.unique(volume)) <= {0, 3, 7} and (volume == 3).any()
    # A moving model still refuses a time outside its range.
    moving = dynaslice.random_model([16, 16], 1, seed=1)
    assert not moving.is_static and moving.time_range[0] < moving.time_range[1]
    with pytest.raises(ValueError, match="outside the model's time range"):
        moving.sdf(p, moving.time_range[1] + 1.0)


def test_sigterm_during_train_saves_the_checkpoint_and_resumes(tmp_path):
    # SIGTERM (timeout, Slurm, docker stop) is handled as `dynaslice train` handles it: the
    # checkpoint is saved, the program ends with status 128 + 15, no lock or temporary is
    # left, and resume=True continues the run.
    import subprocess
    import sys
    import time

    sections = write_sphere_sections(tmp_path / "s.json", frames=2, planes=3)
    out = tmp_path / "m.dsm"
    script = (
        "import sys, dynaslice\n"
        "def seen(p):\n"
        "    if p['step'] >= 3:\n"
        "        print('training', flush=True)\n"
        "dynaslice.train(sys.argv[1], sys.argv[2], steps=100_000, threads=1, progress=seen,\n"
        "                widths=[32, 32], contour_samples=256, plane_samples=256,\n"
        "                space_samples=256)\n"
    )
    child = subprocess.Popen([sys.executable, "-c", script, str(sections), str(out)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == "training", child.stderr.read()
        child.send_signal(signal.SIGTERM)
        _, err = child.communicate(timeout=120)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 128 + signal.SIGTERM, err
    assert "SIGTERM" in err, err
    assert (tmp_path / "m.dsm.ckpt").exists() and not out.exists(), err
    left = [p.name for p in tmp_path.iterdir() if p.name.endswith(".lock") or p.name.startswith(".")]
    assert not left, "left after SIGTERM: %s" % left

    class Stop(Exception):
        pass

    first = []

    def record_and_stop(p):
        first.append(p["step"])
        raise Stop("seen")

    started = time.monotonic()
    with pytest.raises(Stop):
        dynaslice.train(sections, out, steps=100_000, threads=1, progress=record_and_stop,
                        resume=True, **SMALL)
    assert first[0] > 1, "resumed at step %d" % first[0]
    assert time.monotonic() - started < 120
