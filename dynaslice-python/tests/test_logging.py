"""The library's warnings reach Python's logging, and training without tqdm says what to install."""

import builtins
import logging

import dynaslice

SMALL = dict(widths=[16], contour_samples=64, plane_samples=64, space_samples=64)


def write_flipped_csl(path):
    """Two squares at z = 0.3 and z = 0.7; the first plane's D has the wrong sign (its vertices
    lie on Ax + By + Cz = D), which the reader accepts with a warning naming the file."""
    lines = ["CSLC", "2 1", ""]
    for plane, (z, d) in enumerate([(0.3, 0.3), (0.7, -0.7)], start=1):
        lines.append("%d 4 1 0 0 1 %g" % (plane, d))
        lines += ["%g %g %g" % (x, y, z) for x, y in [(0, 0), (1, 0), (1, 1), (0, 1)]]
        lines += ["4 1 0 1 2 3", ""]
    path.write_text("\n".join(lines))
    return path


def test_a_csl_warning_reaches_python_logging(tmp_path, caplog):
    csl = write_flipped_csl(tmp_path / "flipped.csl")
    with caplog.at_level(logging.WARNING):
        dynaslice.train(csl, tmp_path / "m.dsm", steps=1, threads=1, progress=False, **SMALL)
    warnings = [r for r in caplog.records if "Ax + By + Cz = D" in r.getMessage()]
    assert warnings, [r.getMessage() for r in caplog.records]
    record = warnings[0]
    assert record.levelno == logging.WARNING
    assert record.name.startswith("dynaslice_data"), record.name
    assert "flipped.csl" in record.getMessage()


def test_a_level_set_in_python_silences_the_library(tmp_path, caplog):
    csl = write_flipped_csl(tmp_path / "flipped.csl")
    caplog.set_level(logging.WARNING)
    logging.getLogger("dynaslice_data").setLevel(logging.ERROR)
    try:
        dynaslice.train(csl, tmp_path / "m.dsm", steps=1, threads=1, progress=False, **SMALL)
    finally:
        logging.getLogger("dynaslice_data").setLevel(logging.NOTSET)
    assert not [r for r in caplog.records if r.name.startswith("dynaslice_data")]


def test_training_without_tqdm_prints_lines_naming_the_extra(tmp_path, capsys, monkeypatch):
    real_import = builtins.__import__

    def no_tqdm(name, *args, **kwargs):
        if name.startswith("tqdm"):
            raise ImportError("no tqdm here")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_tqdm)
    csl = write_flipped_csl(tmp_path / "square.csl")
    dynaslice.train(csl, tmp_path / "m.dsm", steps=20, threads=1, **SMALL)
    err = capsys.readouterr().err
    assert "dynaslice[progress]" in err, err
    assert "dynaslice train: step" in err, err
