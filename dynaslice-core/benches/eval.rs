//! Single-thread throughput of model evaluation, and the sgemm peak it is judged against.
//!
//! `cargo bench -p dynaslice-core --features std --bench eval` runs every benchmark through
//! criterion and then prints a summary table (points/s, GFLOP/s and % of the sgemm peak) that
//! `docs/performance.md` quotes. The table's times are criterion's own samples: each benchmark
//! records the per-iteration time of every sample it hands criterion, and the table uses the
//! median of the measurement samples, as criterion's "median" estimate does, and also the
//! fastest sample: on a machine shared with other jobs the fastest sample is the least disturbed
//! one, so "best" ratios are the steadier comparison between benchmarks run seconds apart.
//!
//! FLOP convention: 2 · [`Layout::macs_per_point`] per point for f, 4x that for f and ∇ₓf
//! (primal and three tangent rows go through every matrix product); for a motion model the sum
//! of both networks'. Sines, cosines, biases, the first layer's copies and the chain rule's few
//! multiply-adds are not counted, so GFLOP/s is the rate of useful matrix work.
//!
//! Motion models (`+u…` rows) are the same shape network moved by a motion network, measured in
//! the same run as the shape network alone, so their time ratio is the cost of the motion.
//!
//! The sgemm peak is the best of two libraries, measured in the same run: `gemm` (AVX2+FMA on
//! stable Rust; its AVX-512 kernels need its `nightly` feature, so run the bench with
//! `cargo +nightly bench … --features std,gemm/nightly` to include them) and `matrixmultiply`
//! (AVX-512 on stable), both at a large shape and at the block shape our kernels multiply.

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput};
use dynaslice_core::format::{ModelWriter, WeightType};
use dynaslice_core::{Layout, ModelBytes, Scratch};
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Samples per benchmark: criterion's minimum is 10; 15 keeps the median stable on a shared,
/// noisy machine while the whole run stays well under two minutes.
const SAMPLES: usize = 15;
/// Points per batched call: enough blocks (16 to 64 points each) that per-call costs vanish.
const BATCH: usize = 1024;
/// Points per single-point iteration (one `eval` call each).
const SINGLE: usize = 64;
/// Classes of the benchmark models (a multi-class anatomy model).
const CLASSES: u32 = 8;

/// Median and fastest of a benchmark's sample times, in seconds per iteration.
#[derive(Clone, Copy)]
struct Times {
    median: f64,
    best: f64,
}

/// Picks one statistic of [`Times`].
type Stat = fn(Times) -> f64;

/// One measured benchmark: its label and work per iteration.
struct Row {
    label: String,
    points: usize,
    flops: f64,
    times: Option<Times>,
}

/// Runs `routine` as benchmark `id` (one iteration = `points` points) and returns the median
/// and fastest of criterion's per-iteration sample times, or `None` when a filter on the command
/// line skipped it.
fn measure(
    group: &mut BenchmarkGroup<WallTime>,
    id: &str,
    points: usize,
    mut routine: impl FnMut(),
) -> Option<Times> {
    group.throughput(Throughput::Elements(points as u64));
    let mut times = Vec::new();
    group.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                routine();
            }
            let elapsed = start.elapsed();
            times.push(elapsed.as_secs_f64() / iters as f64);
            elapsed
        })
    });
    // Criterion warms up through the same closure first; the measurement samples come last.
    let first = times.len().saturating_sub(SAMPLES);
    let samples = &mut times[first..];
    samples.sort_by(f64::total_cmp);
    let n = samples.len();
    let median = match n {
        0 => return None,
        n if n % 2 == 1 => samples[n / 2],
        n => 0.5 * (samples[n / 2 - 1] + samples[n / 2]),
    };
    Some(Times {
        median,
        best: samples[0],
    })
}

/// C = A·B for row-major A (m × k) and B (k × n) with both libraries; returns the rows.
fn sgemm(group: &mut BenchmarkGroup<WallTime>, m: usize, k: usize, n: usize) -> Vec<Row> {
    let a: Vec<f32> = (0..m * k).map(|i| (i % 7) as f32 * 0.1).collect();
    let b: Vec<f32> = (0..k * n).map(|i| (i % 5) as f32 * 0.1).collect();
    let mut c = vec![0.0f32; m * n];
    let flops = 2.0 * (m * k * n) as f64;
    let shape = format!("{m}x{k}x{n}");
    let gemm_time = measure(group, &format!("gemm/{shape}"), m, || {
        // SAFETY: the pointers and strides describe the three row-major buffers above.
        unsafe {
            gemm::gemm(
                m,
                n,
                k,
                c.as_mut_ptr(),
                1,
                n as isize,
                false,
                a.as_ptr(),
                1,
                k as isize,
                b.as_ptr(),
                1,
                n as isize,
                0.0,
                1.0,
                false,
                false,
                false,
                gemm::Parallelism::None,
            )
        };
        black_box(&mut c);
    });
    let mm_time = measure(group, &format!("matrixmultiply/{shape}"), m, || {
        // SAFETY: as above.
        unsafe {
            matrixmultiply::sgemm(
                m,
                k,
                n,
                1.0,
                a.as_ptr(),
                k as isize,
                1,
                b.as_ptr(),
                n as isize,
                1,
                0.0,
                c.as_mut_ptr(),
                n as isize,
                1,
            )
        };
        black_box(&mut c);
    });
    [("gemm", gemm_time), ("matrixmultiply", mm_time)]
        .into_iter()
        .map(|(lib, times)| Row {
            label: format!("sgemm {lib} {shape}"),
            points: m,
            flops,
            times,
        })
        .collect()
}

/// f and f+∇ₓf, single points and batches, for one model (a motion model when `motion` gives
/// its motion network's widths).
fn model(
    c: &mut Criterion,
    name: &str,
    widths: &[u32],
    motion: Option<&[u32]>,
    weight_type: WeightType,
) -> Vec<Row> {
    let mut writer = match motion {
        Some(m) => ModelWriter::random_motion(widths, CLASSES, m, 1),
        None => ModelWriter::random_siren(widths, CLASSES, 1),
    };
    writer.weight_type = weight_type;
    let bytes = ModelBytes::copy_from(&writer.to_bytes());
    let model = bytes.model().expect("valid benchmark model");
    let layout: &Layout = model.layout();
    let k = layout.num_classes();
    let motion_macs = model.motion().map_or(0, |m| m.layout().macs_per_point());
    let macs = (layout.macs_per_point() + motion_macs) as f64;
    let dtype = match weight_type {
        WeightType::F32 => "f32",
        WeightType::F16 => "f16",
    };
    let label = format!("{name} {dtype}");
    let xyz: Vec<[f32; 3]> = (0..BATCH)
        .map(|i| {
            let s = i as f32 * 0.618;
            [s.sin() * 0.9, (1.3 * s).cos() * 0.8, (0.7 * s).sin() * 0.95]
        })
        .collect();
    let t: Vec<f32> = (0..BATCH).map(|i| (i as f32 * 0.37).fract()).collect();
    let mut scratch = Scratch::boxed();
    let (mut f, mut grad) = (vec![0.0f32; BATCH * k], vec![[0.0f32; 3]; BATCH * k]);

    let mut group = c.benchmark_group(label.replace(' ', "_"));
    let mut rows = Vec::new();
    let mut row = |query: &str, mode: &str, points: usize, flops_per_point: f64, s| {
        rows.push(Row {
            label: format!("{label} {query} {mode}"),
            points,
            flops: flops_per_point * points as f64,
            times: s,
        })
    };

    let s = measure(&mut group, "f/batch", BATCH, || {
        model.eval_batch(&mut scratch, &xyz, &t, &mut f).unwrap();
        black_box(&mut f);
    });
    row("f", "batch", BATCH, 2.0 * macs, s);
    let s = measure(&mut group, "f+grad/batch", BATCH, || {
        model
            .eval_grad_batch(&mut scratch, &xyz, &t, &mut f, &mut grad)
            .unwrap();
        black_box(&mut grad);
    });
    row("f+grad", "batch", BATCH, 8.0 * macs, s);
    let s = measure(&mut group, "f/point", SINGLE, || {
        for (x, &t) in xyz[..SINGLE].iter().zip(&t) {
            model.eval(*x, t, &mut f[..k]).unwrap();
            black_box(&mut f);
        }
    });
    row("f", "point", SINGLE, 2.0 * macs, s);
    let s = measure(&mut group, "f+grad/point", SINGLE, || {
        for (x, &t) in xyz[..SINGLE].iter().zip(&t) {
            model.eval_grad(*x, t, &mut f[..k], &mut grad[..k]).unwrap();
            black_box(&mut grad);
        }
    });
    row("f+grad", "point", SINGLE, 8.0 * macs, s);
    group.finish();
    rows
}

fn main() {
    let mut c = Criterion::default()
        .sample_size(SAMPLES)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_millis(1200))
        .without_plots()
        .configure_from_args();

    let mut group = c.benchmark_group("sgemm");
    group
        .sample_size(SAMPLES)
        .warm_up_time(Duration::from_millis(300));
    // Large: the whole batch as one product (N points × 256 × 256). Block: what our kernels
    // multiply per layer and block (64 rows × 256 × 256), where packing costs more per FLOP.
    let mut peaks = sgemm(&mut group, 4096, 256, 256);
    peaks.extend(sgemm(&mut group, 64, 256, 256));
    group.finish();

    let sine = sine_against_libm(&mut c);

    let mut rows = Vec::new();
    // The paper's size: width 256, 3 hidden 256×256 layers (≈ 200K parameters).
    let paper: &[u32] = &[256; 4];
    // A firmware size: width 64, 3 hidden layers.
    let firmware: &[u32] = &[64; 4];
    for weight_type in [WeightType::F32, WeightType::F16] {
        rows.extend(model(&mut c, "w256x4", paper, None, weight_type));
        rows.extend(model(&mut c, "w64x4", firmware, None, weight_type));
    }
    // Motion models: the paper's shape network moved by a motion network of half its width,
    // and by one as large as itself.
    let (half, same): (&[u32], &[u32]) = (&[128; 3], paper);
    rows.extend(model(
        &mut c,
        "w256x4+u128x3",
        paper,
        Some(half),
        WeightType::F32,
    ));
    rows.extend(model(
        &mut c,
        "w256x4+u256x4",
        paper,
        Some(same),
        WeightType::F32,
    ));

    // GFLOP/s of a row from one statistic of its times, and the sgemm peak for that statistic.
    let gflops = |r: &Row, stat: Stat| r.times.map(|t| r.flops / stat(t) * 1e-9);
    let peak = |stat: Stat| {
        peaks
            .iter()
            .filter_map(|r| gflops(r, stat).map(|g| (g, r.label.as_str())))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    };
    let (median, best): (Stat, Stat) = (|t| t.median, |t| t.best);
    let (peak_median, peak_best) = (peak(median), peak(best));
    println!(
        "\nSummary (one thread, kernel \"{}\"; {SAMPLES} samples each: median and fastest; \
         FLOPs = 2·MACs of the matrix products, ×4 for f+grad; % of the sgemm peak of the same \
         statistic)",
        dynaslice_core::kernel_name()
    );
    println!(
        "{:<34} {:>11} {:>8} {:>7} {:>11} {:>8} {:>7}",
        "benchmark", "points/s", "GFLOP/s", "% peak", "best pts/s", "GFLOP/s", "% peak"
    );
    for r in peaks.iter().chain(&rows) {
        let Some(t) = r.times else { continue };
        let mut line = format!("{:<34}", r.label);
        for (stat, p) in [(median, peak_median), (best, peak_best)] {
            let g = r.flops / stat(t) * 1e-9;
            let points = if r.label.starts_with("sgemm") {
                String::from("-")
            } else {
                format!("{:.3e}", r.points as f64 / stat(t))
            };
            let pct = p.map_or(String::from("-"), |(p, _)| format!("{:.0}%", 100.0 * g / p));
            line += &format!(" {points:>11} {g:>8.1} {pct:>7}");
        }
        println!("{line}");
    }
    for (name, p) in [("median", peak_median), ("best", peak_best)] {
        if let Some((p, label)) = p {
            println!("sgemm peak ({name}): {p:.1} GFLOP/s ({label})");
        }
    }
    c.final_summary();
    sine.print();
}

/// Sines per iteration of the sine benchmarks: a layer's pre-activations for 256 points.
const SINES: usize = 256 * 256;

/// The polynomial sine of `dynaslice_core::sine` against libm's scalar `sinf`, on SIREN-range
/// arguments (|x| ≤ 100): speed of both and the polynomial's largest error against f64 `sin`.
struct SineReport {
    polynomial: Option<Times>,
    libm: Option<Times>,
    max_error: f64,
    libm_max_error: f64,
}

impl SineReport {
    fn print(&self) {
        let (Some(p), Some(l)) = (self.polynomial, self.libm) else {
            return;
        };
        let rate = |t: f64| SINES as f64 / t * 1e-9;
        println!(
            "sine: polynomial {:.2} G/s (median), libm sinf {:.2} G/s: {:.1}x faster; max |error| \
             on |x| <= 100 against f64 sin: polynomial {:.1e}, sinf {:.1e}",
            rate(p.median),
            rate(l.median),
            l.median / p.median,
            self.max_error,
            self.libm_max_error
        );
    }
}

fn sine_against_libm(c: &mut Criterion) -> SineReport {
    let xs: Vec<f32> = (0..SINES)
        .map(|i| -100.0 + 200.0 * i as f32 / SINES as f32)
        .collect();
    let error = |f: &dyn Fn(f32) -> f32| {
        xs.iter()
            .map(|&x| (f64::from(f(x)) - libm::sin(f64::from(x))).abs())
            .fold(0.0, f64::max)
    };
    let max_error = error(&dynaslice_core::sine::sin);
    let libm_max_error = error(&libm::sinf);
    let mut group = c.benchmark_group("sine");
    let mut buf = xs.clone();
    let polynomial = measure(&mut group, "polynomial", SINES, || {
        buf.copy_from_slice(&xs);
        dynaslice_core::sine::sin_in_place(black_box(&mut buf));
    });
    let libm = measure(&mut group, "libm_sinf", SINES, || {
        buf.copy_from_slice(&xs);
        for v in black_box(&mut buf).iter_mut() {
            *v = libm::sinf(*v);
        }
    });
    group.finish();
    SineReport {
        polynomial,
        libm,
        max_error,
        libm_max_error,
    }
}
