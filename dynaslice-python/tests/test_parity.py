"""One way into training: the same input and options through the command line
(`dynaslice train`) and through `dynaslice.train` give byte-identical model files and loss
logs, and the same bad option gives the same words before any work. Both front ends map onto
one training specification (dynaslice_train::spec::TrainSpec and fit). One way out: `info`,
`measure` and `report` give what Model.describe, Model.measure and Model.report give."""

import json
import os
import subprocess

import pytest

import dynaslice
from conftest import built, write_sphere_sections


def cli():
    path = built("DYNASLICE_BIN", "dynaslice")
    if path is None:
        if os.environ.get("DYNASLICE_REQUIRE_PYTHON"):
            pytest.fail("no built `dynaslice` binary: the parity test must run in CI")
        pytest.skip("no built `dynaslice` binary (cargo build -p dynaslice-cli, or set DYNASLICE_BIN)")
    return path


# Every kind of option: counts, reals, lists, flags and the input's own options.
OPTIONS = {
    "steps": 40,
    "seed": 3,
    "threads": 2,
    "widths": [32, 24],
    "omega0": 12.5,
    "lr": 2e-3,
    "warmup_steps": 5,
    "lambda_plane": 0.3,
    "contour_samples": 128,
    "plane_samples": 96,
    "space_samples": 64,
    "class_weights": [1.0, 2.5],
    "frames": "0:3:1",
    "no_orientation": True,
}


def flags(options):
    out = []
    for key, value in options.items():
        flag = "--" + key.replace("_", "-")
        if value is True:
            out.append(flag)
        elif isinstance(value, list):
            out += [flag, ",".join(repr(v) for v in value)]
        else:
            out += [flag, str(value)]
    return out


def test_the_command_line_and_python_write_the_same_model(tmp_path, monkeypatch):
    exe = cli()
    monkeypatch.chdir(tmp_path)
    write_sphere_sections(tmp_path / "s.json", frames=3)
    subprocess.run([str(exe), "train", "s.json", "-o", "cli.dsm"] + flags(OPTIONS),
                   check=True, capture_output=True)
    # The model records its input's path: the same relative one in both runs. Its own name is
    # not recorded, so the two files may differ only if the training differs.
    model = dynaslice.train("s.json", "py.dsm", progress=False, **OPTIONS)
    cli_bytes = (tmp_path / "cli.dsm").read_bytes()
    assert (tmp_path / "py.dsm").read_bytes() == cli_bytes
    assert model.to_bytes() == cli_bytes
    assert (tmp_path / "py.dsm.loss.csv").read_bytes() == (tmp_path / "cli.dsm.loss.csv").read_bytes()
    assert (tmp_path / "py.dsm.loss.png").exists()
    # A finished run leaves no checkpoint behind, through either front end.
    for name in ("cli.dsm", "py.dsm"):
        assert not (tmp_path / (name + ".ckpt")).exists()
        assert not (tmp_path / (name + ".ckpt.loss.csv")).exists()


@pytest.mark.parametrize("key,value,words", [
    ("lr", -1.0, "out of range; allowed: a number > 0 and ≤ 10"),
    ("steps", 0, "out of range; allowed: a whole number from 1 to 10000000"),
    ("checkpoint_minutes", -2.0, "out of range; allowed: a number from 0 to 525600"),
    ("budget_classes", 65, "out of range; allowed: a whole number from 1 to 64"),
    # Input options: the limits of dynaslice_data::input_flags, checked by InputSpec::set.
    ("rotated_planes", 100000, "out of range; allowed: a whole number from 0 to 1000"),
    ("pixel", -1.0, "out of range; allowed: a finite number > 0"),
])
def test_the_same_bad_option_gives_the_same_words_before_any_work(tmp_path, key, value, words):
    exe = cli()
    missing = tmp_path / "not-read.json"  # never read: the option is checked first
    run = subprocess.run([str(exe), "train", str(missing), "-o", str(tmp_path / "m.dsm"),
                          "--" + key.replace("_", "-"), str(value)],
                         capture_output=True, text=True)
    assert run.returncode != 0
    assert words in run.stderr, run.stderr
    with pytest.raises(ValueError) as e:
        dynaslice.train(missing, tmp_path / "m.dsm", progress=False, **{key: value})
    # A training option's message starts `lr: `, an input option's `pixel "-1.0": `.
    named = str(e.value).startswith((key + ": ", f'{key} "{value}": '))
    assert named and str(e.value).endswith(words), str(e.value)
    assert not (tmp_path / "m.dsm").exists()


def test_list_keywords_take_the_command_lines_text(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_sphere_sections(tmp_path / "s.json", frames=3)
    as_lists = dynaslice.train("s.json", "lists.dsm", progress=False, **OPTIONS)
    text = dict(OPTIONS, widths="32,24", class_weights="1.0, 2.5")
    as_text = dynaslice.train("s.json", "text.dsm", progress=False, **text)
    assert as_text.to_bytes() == as_lists.to_bytes()
    with pytest.raises(ValueError) as e:
        dynaslice.train("s.json", "bad.dsm", progress=False, labels="1,x")
    assert str(e.value).startswith('labels "1,x": "x"'), str(e.value)
    assert not (tmp_path / "bad.dsm").exists()


def test_info_measure_and_report_are_the_same_from_both_front_ends(tmp_path, monkeypatch):
    """`info`, `measure --json` and `report` of one model give the same lines, figures and
    page as Model.describe, Model.measure and Model.report: one library call behind each."""
    exe = cli()
    monkeypatch.chdir(tmp_path)

    def run(*args):
        return subprocess.run([str(exe)] + list(args), check=True, capture_output=True,
                              text=True).stdout

    # `info` meshes every class at each of up to 5 times for its extent check (minutes in a
    # debug build): a static model's one time keeps it short.
    write_sphere_sections(tmp_path / "one.json", frames=1)
    static = dynaslice.train("one.json", "static.dsm", progress=False, steps=30, widths=[24, 24])
    info = run("info", "static.dsm").splitlines()
    lines = static.describe()
    assert len(lines) > 5 and info[0] == "model        static.dsm", info
    assert info[1:1 + len(lines)] == lines
    assert info[1 + len(lines)].startswith("extents"), info

    write_sphere_sections(tmp_path / "s.json", frames=3)
    model = dynaslice.train("s.json", "m.dsm", progress=False, steps=30, widths=[24, 24], seed=2)
    t0, t1 = model.time_range
    times = "%r:%r:2" % (t0, t1)
    figures = json.loads(run("measure", "m.dsm", "--json", "--times", times, "--resolution", "16"))
    assert len(figures["classes"]) == model.num_classes, figures
    assert model.measure(times, resolution=16) == figures
    # The same times as a list: the same figures.
    listed = model.measure([t0, t1], resolution=16)
    assert listed["classes"] == figures["classes"]

    run("report", "m.dsm", "s.json", "-o", "cli.html", "--times", times, "--resolution", "16")
    model.report("py.html", ["s.json"], times=times, resolution=16)
    cli_page = (tmp_path / "cli.html").read_bytes()
    assert len(cli_page) > 10000 and (tmp_path / "py.html").read_bytes() == cli_page
    # An existing page is kept unless force=True, in the command's words.
    with pytest.raises(dynaslice.DynasliceError, match="force=True"):
        model.report("py.html", times=times, resolution=16)
    model.report("py.html", times=times, resolution=16, force=True)
    assert (tmp_path / "py.html").read_bytes() != cli_page  # no plane view without the input
    with pytest.raises(ValueError, match="resolution 1: out of range"):
        model.measure(resolution=1)
