//! Throughput of the training step, next to this machine's sgemm peak measured in the same run.
//!
//! FLOP convention: matrix products only (2 FLOPs per multiply-add), counted from the scheme
//! each set uses: with P = `Layout::macs_per_point`, a contour point costs 4P, plus 2P when its
//! orientation hinge is active (one directional tangent, whose backward rows are dropped when
//! the hinge is off, [`super::passes`]), a plane sample 3P, a space-time sample
//! [`SpaceTimeScheme::cost`]·P (12P with forward tangents, (3 + 3K)P reverse over reverse).
//! Sines, the loss and Adam are not counted (they are what makes the step slower than its
//! products).

use super::data_sampler::SampleCounts;
use super::loss::{ContourSample, PlaneKind, PlaneSample};
use super::matmul::{matmul, Mat, Op};
use super::network::{Network, OMEGA_0};
use super::objective::{Batch, Objective, SpaceTimeScheme};
use super::trainer::TrainOptions;
use super::warp;
use dynaslice_core::Layout;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::time::Instant;

/// One configuration's measurement.
#[derive(Clone, Debug)]
pub struct StepReport {
    /// Classes.
    pub num_classes: usize,
    /// The space-time samples' gradient scheme.
    pub scheme: SpaceTimeScheme,
    /// Parameters of the network.
    pub params: usize,
    /// Median seconds per step.
    pub seconds: f64,
    /// Fraction of contour points with an active orientation hinge (their tangent backward runs).
    pub active_contour: f64,
    /// Points (all sets) per second.
    pub points_per_second: f64,
    /// Matrix-product GFLOP/s.
    pub gflops: f64,
}

/// sgemm reference throughput of this machine.
#[derive(Clone, Copy, Debug)]
pub struct Peak {
    /// GFLOP/s of one thread on a 1024³ product.
    pub single: f64,
    /// GFLOP/s of `threads` threads each running their own 1024³ product.
    pub all: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Measures the sgemm peak (the `gemm` crate, the trainer's own product) on `threads` threads.
pub fn sgemm_peak(threads: usize, repeats: usize) -> Peak {
    let n = 1024;
    let a: Vec<f32> = (0..n * n).map(|i| (i % 7) as f32 * 0.1).collect();
    let b = a.clone();
    let once = || {
        let mut c = vec![0.0f32; n * n];
        let start = Instant::now();
        matmul(
            &mut c,
            false,
            Mat::new(&a, n, n),
            Op::N,
            Mat::new(&b, n, n),
            Op::N,
        );
        2.0 * (n * n * n) as f64 / start.elapsed().as_secs_f64() / 1e9
    };
    let single = median((0..repeats).map(|_| once()).collect());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let all = median(
        (0..repeats)
            .map(|_| {
                let start = Instant::now();
                pool.broadcast(|_| once());
                threads as f64 * 2.0 * (n * n * n) as f64 / start.elapsed().as_secs_f64() / 1e9
            })
            .collect(),
    );
    Peak { single, all }
}

/// Random samples of K classes drawn as the trainer would by `counts` (classes of equal
/// contour length), in the normalised frame (the cost does not depend on where they are).
pub fn random_batch(k: usize, counts: &SampleCounts, seed: u64) -> Batch {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut point = || {
        [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(0.0..1.0),
        ]
    };
    let equal = vec![1.0; k];
    let mut b = Batch::default();
    for (c, n) in (0u32..).zip(counts.contour_split(&equal)) {
        for _ in 0..n {
            b.contour_x.push(point());
            b.contour_normal.push([1.0, 0.0, 0.0]);
            b.contour.push(ContourSample {
                class: c,
                weight: 1.0 / n as f32,
            });
        }
    }
    for (c, n) in (0u32..).zip(counts.plane_split(&equal)) {
        for _ in 0..n {
            b.plane_x.push(point());
            b.plane.push(PlaneSample {
                class: c,
                target: 0.1,
                kind: PlaneKind::Sdf,
                weight: 1.0 / n as f32,
            });
        }
    }
    b.space_x = (0..counts.space).map(|_| point()).collect();
    b
}

/// One row of [`step_table`]: one class count's step by one space-time scheme.
#[derive(Clone, Debug)]
pub struct StepRow {
    /// The measurement.
    pub report: StepReport,
    /// Whether the trainer picks this scheme for this class count
    /// ([`SpaceTimeScheme::cheapest`]).
    pub chosen: bool,
    /// A picked scheme's time over the base class count's picked scheme's ([`base_classes`]);
    /// `None` for the other scheme.
    pub ratio: Option<f64>,
}

/// The class count a step table compares every other with: 3 where measured, else the first.
pub fn base_classes(classes: &[usize]) -> Option<usize> {
    match classes.contains(&3) {
        true => Some(3),
        false => classes.first().copied(),
    }
}

/// The training step ([`step`]) of each class count of `classes` by both space-time schemes,
/// in the order of `classes`, each picked scheme compared with the base class count's
/// ([`base_classes`], measured first so that every row can be).
pub fn step_table(
    widths: &[u32],
    classes: &[usize],
    counts: &SampleCounts,
    threads: usize,
    repeats: usize,
) -> Vec<StepRow> {
    let Some(base_k) = base_classes(classes) else {
        return Vec::new();
    };
    let mut base = None;
    let mut rows = Vec::new();
    let order = std::iter::once(base_k).chain(classes.iter().copied().filter(|&k| k != base_k));
    for k in order {
        for scheme in [
            SpaceTimeScheme::ReverseOverReverse,
            SpaceTimeScheme::ForwardTangents,
        ] {
            let report = step(widths, k, scheme, counts, threads, repeats, false);
            let chosen = scheme == SpaceTimeScheme::cheapest(k);
            if chosen && k == base_k {
                base = Some(report.seconds);
            }
            rows.push((k, chosen, report));
        }
    }
    classes
        .iter()
        .flat_map(|&k| rows.iter().filter(move |row| row.0 == k))
        .map(|(_, chosen, report)| StepRow {
            report: report.clone(),
            chosen: *chosen,
            ratio: base.filter(|_| *chosen).map(|b| report.seconds / b),
        })
        .collect()
}

/// A motion model's training step against the same shape network's without motion, measured
/// in the same run with the trainer's scheme for K.
#[derive(Clone, Debug)]
pub struct MotionRow {
    /// The step without motion.
    pub shape: StepReport,
    /// The step with the default motion network ([`crate::warp::MOTION_WIDTHS`]).
    pub motion: StepReport,
}

/// [`MotionRow`] for each class count of `classes`.
pub fn motion_table(
    widths: &[u32],
    classes: &[usize],
    counts: &SampleCounts,
    threads: usize,
    repeats: usize,
) -> Vec<MotionRow> {
    classes
        .iter()
        .map(|&k| {
            let scheme = SpaceTimeScheme::cheapest(k);
            MotionRow {
                shape: step(widths, k, scheme, counts, threads, repeats, false),
                motion: step(widths, k, scheme, counts, threads, repeats, true),
            }
        })
        .collect()
}

/// Median time of a training step (loss, gradient; no sampling) at `widths` with K classes,
/// space-time gradients by `scheme`, samples drawn by `counts`, with the default motion network
/// where `motion` (the FLOP count is the shape network's either way).
pub fn step(
    widths: &[u32],
    k: usize,
    scheme: SpaceTimeScheme,
    counts: &SampleCounts,
    threads: usize,
    repeats: usize,
    motion: bool,
) -> StepReport {
    let layout = Layout::new(widths, k as u32).expect("valid benchmark layout");
    let motion =
        motion.then(|| Network::motion_siren(&warp::MOTION_WIDTHS, warp::MOTION_OMEGA_0, 10.0, 3));
    let net = Network::siren(layout, OMEGA_0, 0.0, 10.0, 1).with_motion(motion);
    let batch = random_batch(k, counts, 2);
    let max_set = batch
        .contour_x
        .len()
        .max(batch.plane_x.len())
        .max(batch.space_x.len());
    let mut objective = Objective::with_scheme(&net, threads, max_set, scheme);
    let weights = TrainOptions::default().loss;
    let mut grad = vec![0.0; net.all_params_len()];
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| objective.evaluate(&net, &batch, &weights, &mut grad)); // warm-up
    let seconds = median(
        (0..repeats)
            .map(|_| {
                let start = Instant::now();
                pool.install(|| objective.evaluate(&net, &batch, &weights, &mut grad));
                start.elapsed().as_secs_f64()
            })
            .collect(),
    );
    let p = layout.macs_per_point() as f64;
    let (contour, plain, space) = (
        batch.contour_x.len() as f64,
        batch.plane_x.len() as f64,
        batch.space_x.len() as f64,
    );
    let active = objective.active_contour_points() as f64;
    let flops =
        2.0 * p * (4.0 * contour + 2.0 * active + 3.0 * plain + scheme.cost(k) as f64 * space);
    StepReport {
        num_classes: k,
        scheme,
        params: layout.param_count(),
        seconds,
        active_contour: active / contour.max(1.0),
        points_per_second: (contour + plain + space) / seconds,
        gflops: flops / seconds / 1e9,
    }
}
