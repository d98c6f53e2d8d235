//! Exact 2D signed distance on one plane (issue: tens of thousands of samples per plane must cost
//! milliseconds): a realistic annotation (three organs, one with a hole, 1 536 segments) queried
//! at 50 000 points spread over the region of interest and concentrated near the contours, as
//! the plane sampler draws them.
//!
//! `cargo bench -p dynaslice-geometry --bench sdf` prints criterion's estimate per plane; the
//! summary line gives the median in milliseconds and ns per sample, and the brute-force cost of
//! the same queries (every segment visited) measured in the same run, for scale.
//!
//! Scaling (issue: a 200 000-point RTSTRUCT contour took 93 s to train on): one contour of
//! 25 000, 50 000 and 200 000 points, its index built and queried at the same 50 000 points
//! (`one_contour/build/N`, `one_contour/50k_queries/N`); the summary lines give the cost per
//! point of building and per sample of querying, and their growth from 25 000 points, measured
//! in the same run. Linear building keeps the build cost per point flat (it falls past 65 536
//! cells, the grid's cap); queries on so dense a contour go to the tree, whose cost far from the
//! contour grows about as √n (see `dynaslice_geometry::sdf`).

use criterion::{Criterion, Throughput};
use dynaslice_geometry::{Point2, Polygon, PolygonSdf};
use std::f64::consts::TAU;
use std::hint::black_box;
use std::time::Instant;

/// A wobbly closed curve of `n` vertices about `c`, counter-clockwise (or clockwise).
fn blob(c: Point2, r: f64, n: usize, ccw: bool) -> Polygon {
    (0..n)
        .map(|i| {
            let a = TAU * i as f64 / n as f64 * if ccw { 1.0 } else { -1.0 };
            let rr = r * (1.0 + 0.15 * (5.0 * a).sin() + 0.05 * (13.0 * a).cos());
            [c[0] + rr * a.cos(), c[1] + rr * a.sin()]
        })
        .collect()
}

fn points(n: usize) -> Vec<Point2> {
    // A fixed low-discrepancy spread over [-100, 100]² mm (half of them near the contours would
    // only make the grid's work smaller; uniform is the harder case for a near-segment index).
    (0..n)
        .map(|i| {
            let u = (i as f64 * 0.754_877_666_246_692_7).fract();
            let v = (i as f64 * 0.569_840_290_998_053_3).fract();
            [-100.0 + 200.0 * u, -100.0 + 200.0 * v]
        })
        .collect()
}

fn brute(polys: &[Polygon], p: Point2) -> f64 {
    let mut best = f64::INFINITY;
    let mut inside = false;
    for poly in polys {
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let t =
                (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
            let (qx, qy) = (a[0] + t * dx - p[0], a[1] + t * dy - p[1]);
            best = best.min(qx * qx + qy * qy);
            if (a[1] > p[1]) != (b[1] > p[1]) && p[0] < a[0] + (p[1] - a[1]) * dx / dy {
                inside = !inside;
            }
        }
    }
    if inside {
        -best.sqrt()
    } else {
        best.sqrt()
    }
}

/// Median of the last (at most 15) recorded times.
fn median(times: &mut [f64]) -> f64 {
    let first = times.len().saturating_sub(15);
    let last = &mut times[first..];
    last.sort_by(f64::total_cmp);
    last[last.len() / 2]
}

/// One contour of 25k, 50k and 200k points: build and query costs, and how they grow.
fn one_contour(c: &mut Criterion, pts: &[Point2]) {
    let region = Some(([-100.0, -100.0], [100.0, 100.0]));
    let mut group = c.benchmark_group("one_contour");
    let mut rows = Vec::new();
    for n in [25_000, 50_000, 200_000] {
        let polys = vec![blob([-10.0, 5.0], 60.0, n, true)];
        let mut build = Vec::new();
        group.throughput(Throughput::Elements(n as u64));
        group.bench_function(format!("build/{n}"), |b| {
            b.iter_custom(|iters| {
                let start = Instant::now();
                for _ in 0..iters {
                    black_box(PolygonSdf::new(black_box(&polys), region));
                }
                let e = start.elapsed();
                build.push(e.as_secs_f64() / iters as f64);
                e
            })
        });
        let sdf = PolygonSdf::new(&polys, region).expect("non-empty");
        let mut query = Vec::new();
        group.throughput(Throughput::Elements(pts.len() as u64));
        group.bench_function(format!("50k_queries/{n}"), |b| {
            b.iter_custom(|iters| {
                let start = Instant::now();
                for _ in 0..iters {
                    let s: f64 = pts.iter().map(|&p| sdf.distance(black_box(p))).sum();
                    black_box(s);
                }
                let e = start.elapsed();
                query.push(e.as_secs_f64() / iters as f64);
                e
            })
        });
        // Spot check against brute force (every 500th point: brute force is O(n) a query).
        let worst = pts
            .iter()
            .step_by(500)
            .map(|&p| (brute(&polys, p) - sdf.distance(p)).abs())
            .fold(0.0f64, f64::max);
        rows.push((n, median(&mut build), median(&mut query), worst));
    }
    group.finish();
    let (n0, b0, q0, _) = rows[0];
    for &(n, b, q, worst) in &rows {
        println!(
            "one contour of {n} points: build {:.1} ms ({:.0} ns per point, x{:.2} of {n0} \
             points' per-point cost); {:.0} ns per sample (x{:.2}); largest difference from \
             brute force {worst:.1e} mm",
            b * 1e3,
            b / n as f64 * 1e9,
            (b / n as f64) / (b0 / n0 as f64),
            q / pts.len() as f64 * 1e9,
            q / q0
        );
    }
}

fn main() {
    let polys = vec![
        blob([-40.0, 10.0], 35.0, 640, true),
        blob([-40.0, 10.0], 12.0, 128, false),
        blob([45.0, -20.0], 30.0, 512, true),
        blob([30.0, 60.0], 15.0, 256, true),
    ];
    let region = Some(([-100.0, -100.0], [100.0, 100.0]));
    let pts = points(50_000);
    let mut c = Criterion::default()
        .sample_size(15)
        .without_plots()
        .configure_from_args();
    let mut group = c.benchmark_group("sdf2d");
    group.throughput(Throughput::Elements(pts.len() as u64));
    let mut build_and_query = Vec::new();
    group.bench_function("build+50k_queries", |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                let sdf = PolygonSdf::new(black_box(&polys), region).expect("non-empty");
                let s: f64 = pts.iter().map(|&p| sdf.distance(p)).sum();
                black_box(s);
            }
            let e = start.elapsed();
            build_and_query.push(e.as_secs_f64() / iters as f64);
            e
        })
    });
    let built = PolygonSdf::new(&polys, region).expect("non-empty");
    let mut query = Vec::new();
    group.bench_function("50k_queries", |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                let s: f64 = pts.iter().map(|&p| built.distance(black_box(p))).sum();
                black_box(s);
            }
            let e = start.elapsed();
            query.push(e.as_secs_f64() / iters as f64);
            e
        })
    });
    group.finish();
    one_contour(&mut c, &pts);
    // Brute force over a tenth of the points (it is ~100x slower), scaled, and checked equal.
    let sdf = PolygonSdf::new(&polys, region).expect("non-empty");
    let start = Instant::now();
    let mut worst = 0.0f64;
    for &p in pts.iter().step_by(10) {
        worst = worst.max((brute(&polys, p) - sdf.distance(p)).abs());
    }
    let brute_per_plane = start.elapsed().as_secs_f64() * 10.0;
    let (per_plane, queries) = (median(&mut build_and_query), median(&mut query));
    println!(
        "\nsdf2d: {} segments, {} samples per plane: median {:.2} ms per plane (index built and \
         queried; {:.2} ms of it querying, {:.0} ns per sample); brute force {:.0} ms per plane ({:.0}x slower); largest \
         difference {worst:.1e} mm",
        polys.iter().map(Vec::len).sum::<usize>(),
        pts.len(),
        per_plane * 1e3,
        queries * 1e3,
        queries / pts.len() as f64 * 1e9,
        brute_per_plane * 1e3,
        brute_per_plane / per_plane
    );
}
