//! Builds and runs real C, C++ and Python hosts against the `dynaslice` C libraries that cargo
//! built for this test run, on models this test writes, and checks their answers against the Rust
//! evaluation of the same models.
//!
//! The libraries are the ones cargo produced for this test binary's profile: a package's
//! cdylib and staticlib are built alongside the rlib the test links, into the `deps` folder the
//! test executable lives in. A missing host tool (gcc, g++, valgrind, python3, pkg-config) skips
//! that host with a message; a failing host fails the test.

use dynaslice_core::format::ModelWriter;
use dynaslice_core::{Domain, Model, Scratch};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Number of reference points: not a multiple of any batch block size (64, 16, 12).
const POINTS: usize = 77;

/// The workspace root (this package's parent).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the package lives in the workspace")
        .to_path_buf()
}

/// The folder holding `libdynaslice.so` and `libdynaslice.a` built for this test run.
fn lib_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let dir = exe
        .parent()
        .expect("the test executable is in a folder")
        .to_path_buf();
    for lib in ["libdynaslice.so", "libdynaslice.a"] {
        assert!(
            dir.join(lib).is_file(),
            "{lib} was not built next to the test executable in {}",
            dir.display()
        );
    }
    dir
}

/// A fresh, empty scratch folder for one test.
fn scratch_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("ffi-hosts")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch folder");
    dir
}

/// True when `tool` runs; otherwise prints why the caller skips (or fails, under
/// `DYNASLICE_REQUIRE_HOSTS`).
fn have(tool: &str, test: &str) -> bool {
    let ok = Command::new(tool)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        // CI installs every tool and sets DYNASLICE_REQUIRE_HOSTS, so a skip there is a failure
        // (a printed notice alone would be swallowed by the test harness).
        assert!(
            std::env::var_os("DYNASLICE_REQUIRE_HOSTS").is_none(),
            "{test}: `{tool}` is not installed but DYNASLICE_REQUIRE_HOSTS is set"
        );
        println!("SKIPPED {test}: `{tool}` is not installed");
    }
    ok
}

/// Runs a command, failing the test with its output unless it exits 0; returns its stdout.
fn run(cmd: &mut Command) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{cmd:?} failed ({}):\n--- stdout\n{stdout}\n--- stderr\n{stderr}",
        out.status
    );
    print!("{stdout}");
    stdout
}

/// Both kinds of model every host is run on: without motion (a version-1 file) and with it.
const KINDS: [bool; 2] = [false, true];

/// The test model: three classes with multi-byte UTF-8 in a name, anisotropic world units,
/// a time range not starting at 0 and metadata, so every world ↔ normalised factor is exercised;
/// with `motion`, the same shape network moved by a motion network (a version-2 file), which
/// the hosts query through the same calls.
fn test_model(motion: bool) -> Vec<u8> {
    let mut w = match motion {
        true => ModelWriter::random_motion(&[32, 32], 3, &[24, 16], 2024),
        false => ModelWriter::random_siren(&[32, 32], 3, 2024),
    };
    w.domain = Domain {
        center: [10.0, -5.0, 3.0],
        scale: [40.0, 50.0, 60.0],
        time_origin: 0.25,
        time_span: 0.8,
        output_scale: 45.0,
    };
    w.classes = vec![
        ("myocardium".into(), 1),
        ("left ventricle".into(), -7),
        ("ünïcödé chamber".into(), 300),
    ];
    w.metadata = "{\"trainer\":\"hosts test\"}".into();
    w.to_bytes()
}

/// Deterministic query points over and beyond the model's bounds and time range.
fn points(model: &Model) -> (Vec<[f32; 3]>, Vec<f32>) {
    let (lo, hi) = model.domain().bounds();
    let (t0, t1) = model.domain().time_range();
    let xyz = (0..POINTS)
        .map(|i| {
            let s = i as f32 * 0.618;
            let u = [s.sin(), (1.3 * s).cos(), (0.7 * s).sin()];
            // 10% beyond the box on each side: extrapolation is answered like any query.
            std::array::from_fn(|d| {
                let mid = 0.5 * (lo[d] + hi[d]);
                mid + 0.55 * (hi[d] - lo[d]) * u[d]
            })
        })
        .collect();
    let t = (0..POINTS)
        .map(|i| t0 + (t1 - t0) * (i as f32 * 0.37).fract())
        .collect();
    (xyz, t)
}

/// A C array initialiser of the bit patterns of `values`.
fn bits(values: impl IntoIterator<Item = f32>) -> String {
    let items: Vec<String> = values
        .into_iter()
        .map(|v| format!("0x{:08x}u", v.to_bits()))
        .collect();
    format!("{{{}}}", items.join(", "))
}

/// `expected.h` for tests/c/api_test.c: the Rust answers, bit for bit.
fn expected_header(bytes: &[u8]) -> String {
    let model = Model::from_bytes(bytes).expect("test model loads");
    let k = model.num_classes();
    let (xyz, t) = points(&model);
    let mut h = String::from("/* Written by dynaslice-ffi/tests/hosts.rs: the Rust answers. */\n");
    writeln!(h, "#define REF_K {k}\n#define REF_N {POINTS}").unwrap();
    let names: Vec<String> = model.classes().map(|c| format!("{:?}", c.name)).collect();
    let labels: Vec<String> = model.classes().map(|c| c.label.to_string()).collect();
    writeln!(
        h,
        "static const char *const REF_NAMES[] = {{{}}};",
        names.join(", ")
    )
    .unwrap();
    writeln!(
        h,
        "static const int32_t REF_LABELS[] = {{{}}};",
        labels.join(", ")
    )
    .unwrap();
    writeln!(
        h,
        "static const char REF_METADATA[] = {:?};",
        model.metadata()
    )
    .unwrap();
    let (lo, hi) = model.domain().bounds();
    let (t0, t1) = model.domain().time_range();
    writeln!(
        h,
        "static const uint32_t REF_BOUNDS[] = {};",
        bits(lo.into_iter().chain(hi))
    )
    .unwrap();
    writeln!(
        h,
        "static const uint32_t REF_TIME_RANGE[] = {};",
        bits([t0, t1])
    )
    .unwrap();
    let table = |name: &str, rows: Vec<Vec<f32>>| {
        let rows: Vec<String> = rows.into_iter().map(bits).collect();
        format!(
            "static const uint32_t {name}[][{}] = {{\n{}}};\n",
            rows[0].matches("0x").count(),
            rows.join(",\n")
        )
    };
    let (mut f, mut g, mut d, mut lab, mut u) = (vec![], vec![], vec![], vec![], vec![]);
    for (x, &t) in xyz.iter().zip(&t) {
        u.push(model.displacement(*x, t).unwrap().to_vec());
        let (mut fk, mut gk, mut dk) = (vec![0.0; k], vec![[0.0; 3]; k], vec![0.0; k]);
        model
            .eval_jacobian(*x, t, &mut fk, &mut gk, &mut dk)
            .unwrap();
        f.push(fk);
        g.push(gk.into_iter().flatten().collect());
        d.push(dk);
        lab.push(model.label(*x, t).to_string());
    }
    let mut scratch = Scratch::boxed();
    let (mut bf, mut bg, mut bl) = (
        vec![0.0; POINTS * k],
        vec![[0.0; 3]; POINTS * k],
        vec![0; POINTS],
    );
    model.eval_batch(&mut scratch, &xyz, &t, &mut bf).unwrap();
    let mut bf2 = vec![0.0; POINTS * k];
    model
        .eval_grad_batch(&mut scratch, &xyz, &t, &mut bf2, &mut bg)
        .unwrap();
    model.label_batch(&mut scratch, &xyz, &t, &mut bl).unwrap();
    let mut bu = vec![[0.0; 3]; POINTS];
    model
        .displacement_batch(&mut scratch, &xyz, &t, &mut bu)
        .unwrap();
    writeln!(
        h,
        "#define REF_MOTION {}",
        u8::from(model.motion().is_some())
    )
    .unwrap();
    h += &table(
        "REF_XYZT",
        xyz.iter()
            .zip(&t)
            .map(|(x, &t)| vec![x[0], x[1], x[2], t])
            .collect(),
    );
    h += &table("REF_F", f);
    h += &table("REF_GRAD", g);
    h += &table("REF_DFDT", d);
    h += &table("REF_DISP", u);
    h += &table("REF_BATCH_DISP", bu.iter().map(|r| r.to_vec()).collect());
    writeln!(
        h,
        "static const uint32_t REF_LABEL[] = {{{}}};",
        lab.join(", ")
    )
    .unwrap();
    h += &table("REF_BATCH_F", bf.chunks(k).map(<[f32]>::to_vec).collect());
    h += &table(
        "REF_BATCH_GRAD",
        bg.chunks(k)
            .map(|r| r.iter().flatten().copied().collect())
            .collect(),
    );
    let bl: Vec<String> = bl.iter().map(u32::to_string).collect();
    writeln!(
        h,
        "static const uint32_t REF_BATCH_LABEL[] = {{{}}};",
        bl.join(", ")
    )
    .unwrap();
    h
}

/// gcc arguments that link the static library, with the system libraries Rust's std needs.
fn static_link(libs: &Path) -> Vec<String> {
    vec![
        libs.join("libdynaslice.a").display().to_string(),
        "-lpthread".into(),
        "-ldl".into(),
        "-lm".into(),
    ]
}

/// gcc arguments that link the shared library and find it at run time. An RPATH, not the
/// newer RUNPATH: cargo's LD_LIBRARY_PATH lists `target/debug` too, which takes precedence over
/// a RUNPATH, and an older `libdynaslice.so` there (from a `cargo build`) would be tested.
fn shared_link(libs: &Path) -> Vec<String> {
    vec![
        format!("-L{}", libs.display()),
        "-ldynaslice".into(),
        "-Wl,--disable-new-dtags".into(),
        format!("-Wl,-rpath,{}", libs.display()),
    ]
}

/// Writes the test model (with `motion` or not) and the C test's expected values; returns the
/// model path.
fn prepare(dir: &Path, motion: bool) -> PathBuf {
    let bytes = test_model(motion);
    let model = dir.join("model.dsm");
    std::fs::write(&model, &bytes).unwrap();
    std::fs::write(dir.join("expected.h"), expected_header(&bytes)).unwrap();
    model
}

/// Compiles tests/c/api_test.c (C11, warnings as errors, with `extra` flags) against one of the
/// libraries.
fn build_c_test(dir: &Path, name: &str, extra: &[&str], link: Vec<String>) -> PathBuf {
    let exe = dir.join(name);
    run(Command::new("gcc")
        .args([
            "-std=c11",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-g",
            "-O1",
        ])
        .args(extra)
        .arg(format!("-I{}", root().join("include").display()))
        .arg(format!("-I{}", dir.display()))
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/c/api_test.c"))
        .arg("-o")
        .arg(&exe)
        .args(link));
    exe
}

#[test]
fn c_host_static_and_shared() {
    if !have("gcc", "C host") {
        return;
    }
    let libs = lib_dir();
    for (name, link) in [
        ("static", static_link(&libs)),
        ("shared", shared_link(&libs)),
    ] {
        for motion in KINDS {
            let dir = scratch_dir(&format!(
                "c-{name}-{}",
                if motion { "motion" } else { "v1" }
            ));
            let model = prepare(&dir, motion);
            let exe = build_c_test(&dir, "api_test", &[], link.clone());
            // Natively the batch kernels are the ones Rust used: answers must match bit for bit.
            let out = run(Command::new(&exe).arg(&model).arg(&dir).arg("exact"));
            assert!(out.contains(" 0 failed"), "{out}");
        }
    }
}

#[test]
fn c_host_under_valgrind() {
    if !have("gcc", "valgrind run") || !have("valgrind", "valgrind run") {
        return;
    }
    let libs = lib_dir();
    for motion in KINDS {
        valgrind_run(&libs, motion);
    }
}

/// One valgrind run of the C host on the test model (`motion` or not).
fn valgrind_run(libs: &Path, motion: bool) {
    let dir = scratch_dir(&format!("valgrind-{motion}"));
    let model = prepare(&dir, motion);
    let exe = build_c_test(&dir, "api_test", &[], shared_link(libs));
    let log = dir.join("valgrind.log");
    // Valgrind's CPU has no AVX-512, so the batch kernels may differ from the ones Rust used
    // natively: "approx" compares batch answers to a tolerance instead of bit for bit.
    run(Command::new("valgrind")
        .args([
            "--error-exitcode=99",
            "--leak-check=full",
            "--show-leak-kinds=all",
        ])
        .args(["--errors-for-leak-kinds=definite,indirect,possible"])
        .arg(format!("--log-file={}", log.display()))
        .arg(&exe)
        .arg(&model)
        .arg(&dir)
        .arg("approx"));
    let report = std::fs::read_to_string(&log).unwrap();
    let summary: Vec<&str> = report
        .lines()
        .filter(|l| {
            l.contains("ERROR SUMMARY") || l.contains("lost:") || l.contains("in use at exit")
        })
        .collect();
    println!("valgrind: {}", summary.join("\n"));
    assert!(report.contains("ERROR SUMMARY: 0 errors"), "{report}");
    assert!(
        report.contains("All heap blocks were freed")
            || report.contains("definitely lost: 0 bytes"),
        "{report}"
    );
}

/// gcc flags of the sanitizer run: AddressSanitizer (with LeakSanitizer) and
/// UndefinedBehaviorSanitizer, every UB check fatal even without `UBSAN_OPTIONS`.
const SANITIZE: [&str; 3] = [
    "-fsanitize=address,undefined",
    "-fno-sanitize-recover=all",
    "-fno-omit-frame-pointer",
];

/// The sanitizers' run-time options: leaks checked at exit, the first report ends the process.
const SANITIZER_ENV: [(&str, &str); 2] = [
    ("ASAN_OPTIONS", "detect_leaks=1:abort_on_error=1"),
    ("UBSAN_OPTIONS", "halt_on_error=1:print_stacktrace=1"),
];

/// Longest the sanitizer run may take (it takes about a second): a hang fails, it does not stall CI.
const SANITIZER_LIMIT: Duration = Duration::from_secs(120);

/// True when gcc builds and runs a program with [`SANITIZE`] (Debian's gcc brings libasan and
/// libubsan through libgcc-N-dev); otherwise skips like [`have`], or fails under
/// `DYNASLICE_REQUIRE_HOSTS`.
fn have_sanitizers(test: &str) -> bool {
    if !have("gcc", test) {
        return false;
    }
    let dir = scratch_dir("sanitizer-probe");
    let src = dir.join("probe.c");
    std::fs::write(&src, "int main(void) { return 0; }\n").unwrap();
    let exe = dir.join("probe");
    let ok = Command::new("gcc")
        .args(SANITIZE)
        .arg(&src)
        .arg("-o")
        .arg(&exe)
        .status()
        .is_ok_and(|s| s.success())
        && Command::new(&exe)
            .envs(SANITIZER_ENV)
            .status()
            .is_ok_and(|s| s.success());
    if !ok {
        assert!(
            std::env::var_os("DYNASLICE_REQUIRE_HOSTS").is_none(),
            "{test}: gcc cannot build with {SANITIZE:?} (libasan/libubsan missing?) but \
             DYNASLICE_REQUIRE_HOSTS is set"
        );
        println!("SKIPPED {test}: gcc cannot build and run a program with {SANITIZE:?}");
    }
    ok
}

/// The C host built with AddressSanitizer, LeakSanitizer and UndefinedBehaviorSanitizer against
/// the cdylib. The host is the instrumented part: its own reads and writes around every call, and
/// every malloc/free and memcpy/memset in the process (the library's too, through the
/// sanitizer's interceptors), are checked; leaks at exit include the library's allocations. Any
/// report, a failed check or a run over [`SANITIZER_LIMIT`] fails.
#[test]
fn c_host_under_sanitizers() {
    if !have_sanitizers("sanitizer run") {
        return;
    }
    let libs = lib_dir();
    for motion in KINDS {
        sanitizer_run(&libs, motion);
    }
}

/// One sanitizer run of the C host on the test model (`motion` or not).
fn sanitizer_run(libs: &Path, motion: bool) {
    let dir = scratch_dir(&format!("sanitizers-{motion}"));
    let model = prepare(&dir, motion);
    let exe = build_c_test(&dir, "api_test", &SANITIZE, shared_link(libs));
    // To files, not pipes: nothing to drain while waiting with a deadline.
    let (out_path, err_path) = (dir.join("stdout.txt"), dir.join("stderr.txt"));
    let start = Instant::now();
    let mut child = Command::new(&exe)
        .arg(&model)
        .arg(&dir)
        .arg("exact")
        .envs(SANITIZER_ENV)
        .stdout(Stdio::from(std::fs::File::create(&out_path).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(&err_path).unwrap()))
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", exe.display()));
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if start.elapsed() > SANITIZER_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let stdout = std::fs::read_to_string(&out_path).unwrap();
    let stderr = std::fs::read_to_string(&err_path).unwrap();
    let status = status.unwrap_or_else(|| {
        panic!("the sanitizer run took over {SANITIZER_LIMIT:?}:\n{stdout}\n{stderr}")
    });
    println!(
        "sanitizer run: {status} in {:.2} s; {}",
        start.elapsed().as_secs_f64(),
        stdout.trim()
    );
    let report = ["AddressSanitizer", "LeakSanitizer", "runtime error:"]
        .iter()
        .any(|r| stderr.contains(r));
    assert!(
        status.success() && !report && stdout.contains(" 0 failed"),
        "the C host under ASan/UBSan failed ({status}):\n--- stdout\n{stdout}\n--- stderr\n{stderr}"
    );
}

#[test]
fn cpp_host_eight_threads() {
    if !have("g++", "C++ host") {
        return;
    }
    let libs = lib_dir();
    let dir = scratch_dir("cpp");
    let exe = dir.join("threads_test");
    run(Command::new("g++")
        .args([
            "-std=c++17",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-O1",
            "-pthread",
        ])
        .arg(format!("-I{}", root().join("include").display()))
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/cpp/threads_test.cpp"))
        .arg("-o")
        .arg(&exe)
        .args(shared_link(&libs)));
    for motion in KINDS {
        let model = dir.join(format!("model-{motion}.dsm"));
        std::fs::write(&model, test_model(motion)).unwrap();
        let out = run(Command::new(&exe).arg(&model).arg("8"));
        assert!(out.contains("8 threads: bit-identical"), "{out}");
    }
}

/// The guide's example (docs/c-api.md) is examples/c/quickstart.c verbatim, and it runs.
#[test]
fn docs_example_compiles_and_runs() {
    let source = std::fs::read_to_string(root().join("examples/c/quickstart.c")).unwrap();
    let guide = std::fs::read_to_string(root().join("docs/c-api.md")).unwrap();
    assert!(
        guide.contains(&format!("```c\n{source}```")),
        "docs/c-api.md must quote examples/c/quickstart.c verbatim in a ```c block"
    );
    assert!(
        source.lines().count() <= 30,
        "the guide's example should stay short"
    );
    if !have("gcc", "docs example") {
        return;
    }
    let libs = lib_dir();
    let dir = scratch_dir("quickstart");
    let model = dir.join("model.dsm");
    std::fs::write(&model, test_model(false)).unwrap();
    let exe = dir.join("quickstart");
    run(Command::new("gcc")
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic"])
        .arg(format!("-I{}", root().join("include").display()))
        .arg(root().join("examples/c/quickstart.c"))
        .arg("-o")
        .arg(&exe)
        .args(shared_link(&libs)));
    let out = run(Command::new(&exe).arg(&model));
    let m = Model::from_bytes(&test_model(false)).map(|m| {
        let (lo, hi) = m.domain().bounds();
        let centre = std::array::from_fn(|d| 0.5 * (lo[d] + hi[d]));
        (m.label(centre, m.domain().time_range().0), m.num_classes())
    });
    let (label, k) = m.unwrap();
    assert!(out.contains(&format!("{k} classes")), "{out}");
    assert!(out.contains("class 2: left ventricle (label -7)"), "{out}");
    assert!(
        out.contains(&format!("label at the centre: {label}")),
        "{out}"
    );
    // A missing file is reported through the error functions.
    let missing = Command::new(&exe)
        .arg(dir.join("missing.dsm"))
        .output()
        .unwrap();
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("could not be read"));
}

/// The install step of docs/c-api.md, then a build through `pkg-config --cflags --libs`.
/// Installs the library with install.sh into `dir`/prefix and returns the prefix.
fn install(dir: &Path) -> PathBuf {
    let prefix = dir.join("prefix");
    run(Command::new("sh")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("install.sh"))
        .arg(&prefix)
        .arg(lib_dir()));
    prefix
}

/// A CMake host finds the installed package (`find_package(dynaslice 0.1 REQUIRED)`) and links
/// the guide's example against both imported targets, which then run.
#[test]
fn cmake_find_package() {
    if !have("cmake", "CMake package") || !have("gcc", "CMake package") {
        return;
    }
    let dir = scratch_dir("cmake");
    let prefix = install(&dir);
    let src = dir.join("src");
    std::fs::create_dir_all(&src).unwrap();
    std::fs::write(
        src.join("CMakeLists.txt"),
        format!(
            "cmake_minimum_required(VERSION 3.16)\nproject(consumer C)\n\
             find_package(dynaslice 0.1 REQUIRED)\n\
             add_executable(shared {q})\ntarget_link_libraries(shared PRIVATE dynaslice::dynaslice)\n\
             add_executable(static {q})\ntarget_link_libraries(static PRIVATE dynaslice::dynaslice_static)\n",
            q = root().join("examples/c/quickstart.c").display()
        ),
    )
    .unwrap();
    let build = dir.join("build");
    run(Command::new("cmake")
        .arg("-S")
        .arg(&src)
        .arg("-B")
        .arg(&build)
        .arg(format!("-DCMAKE_PREFIX_PATH={}", prefix.display())));
    run(Command::new("cmake").arg("--build").arg(&build));
    let model = dir.join("model.dsm");
    std::fs::write(&model, test_model(false)).unwrap();
    for exe in ["shared", "static"] {
        let out = run(Command::new(build.join(exe))
            .env("LD_LIBRARY_PATH", prefix.join("lib"))
            .arg(&model));
        assert!(out.contains("3 classes"), "{exe}: {out}");
    }
}

#[test]
fn install_and_pkg_config() {
    if !have("gcc", "pkg-config build") || !have("pkg-config", "pkg-config build") {
        return;
    }
    let dir = scratch_dir("install");
    let prefix = install(&dir);
    for file in [
        "include/dynaslice.h",
        "include/dynaslice_vtk.h",
        "lib/libdynaslice.so",
        "lib/libdynaslice.a",
        "lib/pkgconfig/dynaslice.pc",
        "lib/cmake/dynaslice/dynasliceConfig.cmake",
        "lib/cmake/dynaslice/dynasliceConfigVersion.cmake",
    ] {
        assert!(
            prefix.join(file).is_file(),
            "install.sh did not install {file}"
        );
    }
    let pc = |args: &[&str]| {
        let out = run(Command::new("pkg-config")
            .env("PKG_CONFIG_PATH", prefix.join("lib/pkgconfig"))
            .args(args)
            .arg("dynaslice"));
        out.split_whitespace().map(String::from).collect::<Vec<_>>()
    };
    assert_eq!(pc(&["--modversion"]), [env!("CARGO_PKG_VERSION")]);
    let model = dir.join("model.dsm");
    std::fs::write(&model, test_model(false)).unwrap();
    for (name, args) in [
        ("shared", &["--cflags", "--libs"][..]),
        ("static", &["--cflags", "--libs", "--static"][..]),
    ] {
        let exe = dir.join(format!("quickstart-{name}"));
        let mut flags = pc(args);
        if name == "static" {
            // pkg-config cannot prefer an archive over a shared library of the same name.
            flags = flags
                .into_iter()
                .map(|f| {
                    if f == "-ldynaslice" {
                        "-l:libdynaslice.a".into()
                    } else {
                        f
                    }
                })
                .collect();
        }
        run(Command::new("gcc")
            .args(["-std=c11", "-Wall", "-Wextra", "-Werror"])
            .arg(root().join("examples/c/quickstart.c"))
            .arg("-o")
            .arg(&exe)
            .args(&flags)
            .arg(format!("-Wl,-rpath,{}", prefix.join("lib").display())));
        let out = run(Command::new(&exe).arg(&model));
        assert!(out.contains("3 classes"), "{out}");
    }
}

#[test]
fn python_ctypes_binding() {
    if !have("python3", "Python host") {
        return;
    }
    let libs = lib_dir();
    for motion in KINDS {
        python_run(&libs, motion);
    }
}

/// The ctypes binding on the test model (`motion` or not), against the Rust values.
fn python_run(libs: &Path, motion: bool) {
    let dir = scratch_dir(&format!("python-{motion}"));
    let bytes = test_model(motion);
    let path = dir.join("model.dsm");
    std::fs::write(&path, &bytes).unwrap();
    let model = Model::from_bytes(&bytes).unwrap();
    let (xyz, t) = points(&model);
    let k = model.num_classes();
    // A few points, as JSON: the script must reproduce the Rust values bit for bit.
    let mut cases = Vec::new();
    for i in [0, 5, 40] {
        let mut f = vec![0.0; k];
        let mut g = vec![[0.0; 3]; k];
        model.eval_grad(xyz[i], t[i], &mut f, &mut g).unwrap();
        let to_bits = |v: &[f32]| {
            v.iter()
                .map(|x| x.to_bits().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        cases.push(format!(
            "{{\"xyz\": [{}], \"t\": {}, \"f\": [{}], \"grad\": [{}], \"label\": {}, \
             \"displacement\": [{}]}}",
            to_bits(&xyz[i]),
            t[i].to_bits(),
            to_bits(&f),
            to_bits(g.as_flattened()),
            model.label(xyz[i], t[i]),
            to_bits(&model.displacement(xyz[i], t[i]).unwrap())
        ));
    }
    let names: Vec<String> = model
        .classes()
        .map(|c| format!("[{:?}, {}]", c.name, c.label))
        .collect();
    let expected = format!(
        "{{\"classes\": [{}], \"cases\": [{}]}}",
        names.join(", "),
        cases.join(", ")
    );
    let json = dir.join("expected.json");
    std::fs::write(&json, expected).unwrap();
    let out = run(Command::new("python3")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/check_binding.py"))
        .arg(&path)
        .arg(&json)
        .env("DYNASLICE_LIBRARY", libs.join("libdynaslice.so"))
        .env("PYTHONPATH", root().join("examples/python")));
    assert!(out.contains("python binding: ok"), "{out}");
}
