//! Every command's outputs (issues 28 and 29): no existing file, sidecar, series file or
//! symbolic link is replaced without `--force`; new files get the mode a plain `File::create`
//! gives under the caller's umask; a second run on an output another run is writing refuses at
//! once and leaves nothing; the temporaries of killed runs are removed.

use dynaslice_test_support::fixtures::{succeeded, two_organ_model};
use dynaslice_test_support::spheres::{self, Sphere};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A command writing into a folder: its arguments, `{M}` standing for the model and `{D}` for
/// the folder.
struct Case {
    what: &'static str,
    args: &'static [&'static str],
}

/// One small run of each writing command, each quick on the two-organ model.
const CASES: [Case; 10] = [
    Case {
        what: "mesh, one class",
        args: &[
            "mesh",
            "{M}",
            "--time",
            "0.4",
            "--class",
            "1",
            "--resolution",
            "8",
            "-o",
            "{D}/t.ply",
        ],
    },
    Case {
        what: "mesh, per-class files beside -o",
        args: &[
            "mesh",
            "{M}",
            "--time",
            "0.4",
            "--resolution",
            "8",
            "-o",
            "{D}/t.stl",
        ],
    },
    Case {
        what: "mesh series",
        args: &[
            "mesh",
            "{M}",
            "--times",
            "0:0.8:2",
            "--resolution",
            "8",
            "-o",
            "{D}/series",
        ],
    },
    Case {
        what: "picture --3d",
        args: &[
            "picture",
            "--3d",
            "{M}",
            "--resolution",
            "8",
            "--size",
            "96",
            "-o",
            "{D}/p.png",
        ],
    },
    Case {
        what: "eval volume",
        args: &[
            "eval",
            "volume",
            "{M}",
            "--times",
            "0:0.8:2",
            "--resolution",
            "8",
            "-o",
            "{D}/v.csv",
        ],
    },
    Case {
        what: "labels NIfTI",
        args: &[
            "labels",
            "{M}",
            "--times",
            "0:0.8:2",
            "--spacing",
            "8",
            "-o",
            "{D}/lab.nii.gz",
        ],
    },
    Case {
        what: "labels .seg.nrrd",
        args: &[
            "labels",
            "{M}",
            "--times",
            "0:0.8:2",
            "--spacing",
            "8",
            "-o",
            "{D}/lab.seg.nrrd",
        ],
    },
    Case {
        what: "man",
        args: &["man", "-o", "{D}/man1"],
    },
    Case {
        what: "report",
        args: &[
            "report",
            "{M}",
            "--times",
            "0:0.8:2",
            "--resolution",
            "8",
            "-o",
            "{D}/r.html",
        ],
    },
    Case {
        what: "measure --itv",
        args: &[
            "measure",
            "{M}",
            "--times",
            "0:0.8:2",
            "--resolution",
            "8",
            "--itv",
            "{D}/itv",
        ],
    },
];

/// The writing commands whose output is several files, which must appear all or none.
const MULTI_FILE: [&str; 5] = [
    "mesh, per-class files beside -o",
    "mesh series",
    "labels NIfTI",
    "labels .seg.nrrd",
    "measure --itv",
];

fn args(case: &Case, model: &Path, dir: &Path) -> Vec<String> {
    case.args
        .iter()
        .map(|a| {
            a.replace("{M}", model.to_str().unwrap())
                .replace("{D}", dir.to_str().unwrap())
        })
        .collect()
}

fn dynaslice(args: &[String]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .output()
        .unwrap()
}

/// `dynaslice` under `umask`, through the shell (the umask is the process's).
fn dynaslice_with_umask(umask: &str, args: &[String]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!("umask {umask} && exec \"$@\""))
        .arg("sh")
        .arg(env!("CARGO_BIN_EXE_dynaslice"))
        .args(args)
        .output()
        .unwrap()
}

/// Every entry under `dir` (recursively, folders as entries too) with its content: a file's
/// bytes, a link's target, nothing for a folder.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut all = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let meta = std::fs::symlink_metadata(&p).unwrap();
            let rel = p.strip_prefix(dir).unwrap().to_path_buf();
            if meta.file_type().is_symlink() {
                let target = std::fs::read_link(&p).unwrap();
                all.insert(rel, target.to_string_lossy().as_bytes().to_vec());
            } else if meta.is_dir() {
                all.insert(rel, Vec::new());
                stack.push(p);
            } else {
                all.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    all
}

fn model_in(dir: &Path) -> PathBuf {
    let model = dir.join("model.dsm");
    std::fs::write(&model, two_organ_model(true)).unwrap();
    model
}

/// The files `case` writes, relative to its folder (a fresh run).
fn outputs_of(case: &Case, model: &Path) -> Vec<PathBuf> {
    let dir = tempfile::tempdir().unwrap();
    succeeded(&dynaslice(&args(case, model, dir.path())));
    let files: Vec<PathBuf> = snapshot(dir.path())
        .into_iter()
        .filter(|(p, _)| dir.path().join(p).is_file())
        .map(|(p, _)| p)
        .collect();
    assert!(!files.is_empty(), "{}: wrote nothing", case.what);
    assert!(
        files
            .iter()
            .all(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.')),
        "{}: temporaries or lock files left: {files:?}",
        case.what
    );
    files
}

#[test]
fn no_output_replaces_an_existing_file_or_link_without_force() {
    let home = tempfile::tempdir().unwrap();
    let model = model_in(home.path());
    // A user's file elsewhere, which links at an output point to.
    let reference = home.path().join("reference.stl");
    std::fs::write(&reference, b"solid the user's reference\nendsolid\n").unwrap();
    for case in &CASES {
        let files = outputs_of(case, &model);
        // Each written file in turn already there: as a file, a link to the user's file, or a
        // dangling link. The run must refuse, name --force, and change nothing.
        for (i, file) in files.iter().enumerate() {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join(file);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            match i % 3 {
                0 => std::fs::write(&path, b"a user's file").unwrap(),
                1 => std::os::unix::fs::symlink(&reference, &path).unwrap(),
                _ => std::os::unix::fs::symlink(dir.path().join("nowhere"), &path).unwrap(),
            }
            let before = snapshot(dir.path());
            let kept = std::fs::read(&reference).unwrap();
            let out = dynaslice(&args(case, &model, dir.path()));
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{}: {file:?} {err}", case.what);
            assert!(
                err.contains("--force")
                    && err.contains(&*file.file_name().unwrap().to_string_lossy()),
                "{}: {file:?}: {err}",
                case.what
            );
            assert_eq!(
                snapshot(dir.path()),
                before,
                "{}: {file:?} changed",
                case.what
            );
            assert_eq!(std::fs::read(&reference).unwrap(), kept);
        }
        // With --force, the same run replaces them all (links replaced, their targets kept).
        let dir = tempfile::tempdir().unwrap();
        for file in &files {
            let path = dir.path().join(file);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::os::unix::fs::symlink(&reference, &path).unwrap();
        }
        let kept = std::fs::read(&reference).unwrap();
        let mut forced = args(case, &model, dir.path());
        forced.push("--force".into());
        succeeded(&dynaslice(&forced));
        for file in &files {
            let meta = std::fs::symlink_metadata(dir.path().join(file)).unwrap();
            assert!(meta.is_file(), "{}: {file:?} not replaced", case.what);
        }
        assert_eq!(std::fs::read(&reference).unwrap(), kept, "{}", case.what);
    }
}

/// The names of the files under `dir`, recursively, relative to it.
fn file_names(dir: &Path) -> Vec<PathBuf> {
    snapshot(dir)
        .into_keys()
        .filter(|p| dir.join(p).is_file())
        .collect()
}

/// A multi-file output written with `--force` over an earlier, larger one of the same kind (a
/// longer series, more classes) leaves exactly the files a fresh run writes, and the user's own
/// file in the folder: none of the earlier set's extra files (issue 37).
#[test]
fn a_forced_smaller_multi_file_output_leaves_none_of_the_earlier_files() {
    let home = tempfile::tempdir().unwrap();
    let two = model_in(home.path());
    // A model of the first organ alone (as if retrained without the second): its ITV files
    // replace the earlier ones of that class, so the earlier folder is this output's.
    let one = home.path().join("liver.dsm");
    let liver = Sphere::new([0.1, 0.0, 0.0], 0.3, 0.1);
    std::fs::write(&one, spheres::model(&[liver], &[("liver", 1)])).unwrap();
    let (two, one) = (two.to_str().unwrap(), one.to_str().unwrap());
    // (what, its arguments with `{X}` standing for what differs and `{D}` for the folder, the
    // larger run's X, the smaller run's X).
    let runs = [
        (
            "mesh series",
            "mesh {M} --times {X} --resolution 8 -o {D}/s",
            "0:0.8:3",
            "0:0.8:2",
        ),
        (
            "labels .seg.nrrd frames",
            "labels {M} --times {X} --spacing 8 -o {D}/s/l.seg.nrrd",
            "0:0.8:3",
            "0:0.8:2",
        ),
        (
            "measure --itv",
            "measure {X} --times 0:0.8:2 --resolution 8 --itv {D}/s",
            two,
            one,
        ),
    ];
    let argv = |line: &str, x: &str, dir: &Path| -> Vec<String> {
        line.split(' ')
            .map(|a| {
                a.replace("{M}", two)
                    .replace("{X}", x)
                    .replace("{D}", dir.to_str().unwrap())
            })
            .collect()
    };
    for (what, line, larger, smaller) in runs {
        // The folder exists (labels writes into an existing one; the others make it).
        let fresh = tempfile::tempdir().unwrap();
        std::fs::create_dir(fresh.path().join("s")).unwrap();
        succeeded(&dynaslice(&argv(line, smaller, fresh.path())));
        let mut want = file_names(fresh.path());
        want.push(PathBuf::from("s/notes.txt"));
        want.sort();

        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("s")).unwrap();
        succeeded(&dynaslice(&argv(line, larger, dir.path())));
        let before = file_names(dir.path()).len();
        std::fs::write(dir.path().join("s/notes.txt"), b"mine").unwrap();
        let mut forced = argv(line, smaller, dir.path());
        forced.push("--force".into());
        succeeded(&dynaslice(&forced));
        assert_eq!(
            file_names(dir.path()),
            want,
            "{what} (the larger run wrote {before})"
        );
        assert!(
            before + 1 > want.len(),
            "{what}: the larger run is not larger"
        );
    }
}

#[test]
fn new_outputs_get_the_mode_file_create_gives() {
    use std::os::unix::fs::PermissionsExt;
    let home = tempfile::tempdir().unwrap();
    let model = model_in(home.path());
    for (umask, mask) in [("022", 0o022), ("077", 0o077)] {
        for case in &CASES {
            let dir = tempfile::tempdir().unwrap();
            succeeded(&dynaslice_with_umask(
                umask,
                &args(case, &model, dir.path()),
            ));
            for (file, _) in snapshot(dir.path()) {
                let meta = std::fs::metadata(dir.path().join(&file)).unwrap();
                // What File::create and create_dir give: 0644 and 0755 under umask 022.
                let want = if meta.is_dir() { 0o777 } else { 0o666 } & !mask;
                let mode = meta.permissions().mode() & 0o777;
                assert_eq!(
                    mode, want,
                    "{}: {file:?} is {mode:o} under umask {umask}",
                    case.what
                );
            }
        }
    }
}

#[test]
fn a_run_on_an_output_another_run_is_writing_refuses_and_leaves_nothing() {
    let home = tempfile::tempdir().unwrap();
    let model = model_in(home.path());
    for case in &CASES {
        let dir = tempfile::tempdir().unwrap();
        let argv = args(case, &model, dir.path());
        // The main output: the value after -o (--itv for measure's folder).
        let option = argv.iter().position(|a| a == "-o" || a == "--itv").unwrap();
        let output = PathBuf::from(&argv[option + 1]);
        // Another run's claim, held by this process as the other run would hold it.
        let claim = dynaslice_output::claim(&output).unwrap();
        let before = snapshot(dir.path());
        let out = dynaslice(&argv);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{}: {err}", case.what);
        assert!(
            err.contains("is writing this output")
                && err.contains(&format!("process {}", std::process::id())),
            "{}: {err}",
            case.what
        );
        assert_eq!(snapshot(dir.path()), before, "{}", case.what);
        drop(claim);
        succeeded(&dynaslice(&argv));
    }
}

#[test]
fn two_runs_at_once_on_one_output_never_mix() {
    let home = tempfile::tempdir().unwrap();
    let model = model_in(home.path());
    // Two label volumes of different grids (4 and 6 mm voxels) on one -o, started together,
    // --force so that both may run when they do not overlap: each either refuses because the
    // other is writing, or writes all of its files; what is left is one run's, whole.
    for round in 0..4 {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("lab.nii.gz");
        let run = |spacing: &str| {
            Command::new(env!("CARGO_BIN_EXE_dynaslice"))
                .args(["labels", model.to_str().unwrap(), "--times", "0:0.8:3"])
                .args(["--spacing", spacing, "--force", "-o", out.to_str().unwrap()])
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (a, b) = (run("4"), run("6"));
        let results = [a.wait_with_output().unwrap(), b.wait_with_output().unwrap()];
        for r in &results {
            let err = String::from_utf8_lossy(&r.stderr);
            assert!(
                r.status.success() || err.contains("is writing this output"),
                "round {round}: {err}"
            );
        }
        assert!(
            results.iter().any(|r| r.status.success()),
            "round {round}: neither run finished"
        );
        let volume = dynaslice_data::nifti::read_volume(&out).unwrap();
        assert_eq!(volume.frames, 3, "round {round}");
        let spacing = volume.affine[0][0].abs();
        assert!(
            (spacing - 4.0).abs() < 1e-6 || (spacing - 6.0).abs() < 1e-6,
            "round {round}: {spacing} mm voxels"
        );
        let files: Vec<String> = snapshot(dir.path())
            .into_keys()
            .map(|p| p.to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            files,
            ["lab.ctbl", "lab.label.txt", "lab.nii.gz"],
            "round {round}: leftovers"
        );
    }
}

#[test]
fn temporaries_of_killed_runs_are_removed_and_live_ones_kept() {
    let home = tempfile::tempdir().unwrap();
    let model = model_in(home.path());
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lab.nii.gz");
    let dead = [
        ".lab.nii.gz.Ab3dE9.nii.gz",
        ".lab.nii.gz.tmp",
        ".lab.ctbl.x1Y2z3.ctbl",
    ];
    for name in dead {
        std::fs::write(dir.path().join(name), b"half a volume").unwrap();
    }
    // A live writer's temporary of another output in the same folder.
    let (_live, live) =
        dynaslice_output::create_temporary(&dir.path().join("other.nii.gz")).unwrap();
    let o = dynaslice(&[
        "labels".into(),
        model.to_string_lossy().into_owned(),
        "--spacing".into(),
        "8".into(),
        "--times".into(),
        "0:0.8:2".into(),
        "-o".into(),
        out.to_string_lossy().into_owned(),
    ]);
    succeeded(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    for name in dead {
        assert!(!dir.path().join(name).exists(), "{name} left");
        assert!(err.contains(name), "{name} not reported: {err}");
    }
    assert!(live.exists(), "a live writer's temporary was removed");
}

/// Mounts a tmpfs of `pages` 4 KiB pages at `dir` (unmounted when the guard drops), or `None`
/// where mounting is not permitted (not root, a container without the capability).
fn small_disk(dir: &Path, pages: u64) -> Option<Unmount> {
    let ok = Command::new("mount")
        .args([
            "-t",
            "tmpfs",
            "-o",
            &format!("size={}k", 4 * pages),
            "tmpfs",
        ])
        .arg(dir)
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    ok.then(|| Unmount(dir.to_path_buf()))
}

struct Unmount(PathBuf);

impl Drop for Unmount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// Pages a tmpfs holding `files` (under `dir`) uses: each file's size rounded up to pages.
fn pages_of(dir: &Path) -> u64 {
    snapshot(dir)
        .into_iter()
        .filter(|(p, _)| dir.join(p).is_file())
        .map(|(_, bytes)| (bytes.len() as u64).div_ceil(4096))
        .sum()
}

/// Issue 37: every multi-file output on a disk that fills up at some point of the run (a
/// tmpfs of sizes from one page to what the whole output needs, lock files included)
/// either succeeds whole or fails leaving the folder exactly as it was: nothing new in an empty
/// folder, and with --force over an earlier output of the same run the earlier files intact.
#[test]
fn multi_file_outputs_are_all_or_nothing_when_the_disk_fills() {
    let home = tempfile::tempdir().unwrap();
    let model = model_in(home.path());
    let probe = tempfile::tempdir().unwrap();
    let Some(mounted) = small_disk(probe.path(), 1) else {
        eprintln!("skipped: cannot mount a tmpfs here (needs root)");
        return;
    };
    drop(mounted);
    for case in CASES.iter().filter(|c| MULTI_FILE.contains(&c.what)) {
        // What a whole output takes, from a run on an ordinary disk.
        let whole = tempfile::tempdir().unwrap();
        succeeded(&dynaslice(&args(case, &model, whole.path())));
        let needed = pages_of(whole.path());
        let earlier = snapshot(whole.path());
        let (mut failed, mut whole_runs) = (0, 0);
        for forced in [false, true] {
            let base = if forced { needed } else { 0 };
            // Sizes from one page to past the whole output (lock files and a series folder's
            // entries take pages too), at most 6 of them to keep the test short.
            let top = needed + 8;
            let sizes = (1..top).step_by((top as usize).div_ceil(6)).chain([top]);
            for pages in sizes {
                let dir = tempfile::tempdir().unwrap();
                let _disk = small_disk(dir.path(), base + pages).expect("mounted above");
                let mut argv = args(case, &model, dir.path());
                if forced {
                    // The earlier output, then a different run over it (the other mesh format's
                    // bytes differ too: another resolution).
                    for (rel, bytes) in &earlier {
                        let path = dir.path().join(rel);
                        if bytes.is_empty() && whole.path().join(rel).is_dir() {
                            std::fs::create_dir_all(&path).unwrap();
                        } else {
                            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                            std::fs::write(&path, bytes).unwrap();
                        }
                    }
                    argv.push("--force".into());
                    if let Some(i) = argv.iter().position(|a| a == "--resolution") {
                        argv[i + 1] = "12".into();
                    }
                }
                let before = snapshot(dir.path());
                let out = dynaslice(&argv);
                let err = String::from_utf8_lossy(&out.stderr);
                let after = snapshot(dir.path());
                if out.status.success() {
                    whole_runs += 1;
                    let names: Vec<_> = after.keys().collect();
                    assert_eq!(
                        names,
                        earlier.keys().collect::<Vec<_>>(),
                        "{} on {pages} pages: a successful run left other files",
                        case.what
                    );
                } else {
                    failed += 1;
                    assert_eq!(out.status.code(), Some(1), "{}: {err}", case.what);
                    assert!(
                        err.contains("No space left"),
                        "{} on {pages} pages: {err}",
                        case.what
                    );
                    assert_eq!(
                        after,
                        before,
                        "{} on {pages} pages ({}): a failed run changed the folder: {err}",
                        case.what,
                        if forced {
                            "over an earlier output"
                        } else {
                            "empty folder"
                        }
                    );
                }
            }
        }
        assert!(
            failed > 0 && whole_runs > 0,
            "{}: {failed} failed and {whole_runs} whole runs: the sizes did not span the output",
            case.what
        );
    }
}
