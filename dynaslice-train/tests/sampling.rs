//! Samplers: determinism, geometry of contour samples, exactness of plane targets, absences.

use dynaslice_sequence::{Annotation, ClassInfo, Frame, Plane, Rect, Sequence};
use dynaslice_synth::{slice_sequence, BenchmarkOptions, Shape};
use dynaslice_train::sampling::*;

/// Two classes on two tilted planes at two times: a disc-like polygon with a hole for class 0,
/// absent class 1 on the first plane, a square of class 1 on the second.
fn sequence() -> Sequence {
    let ring = |r: f64, n: usize| -> Vec<[f64; 2]> {
        (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                [r * a.cos(), r * a.sin()]
            })
            .collect()
    };
    let s = std::f64::consts::FRAC_1_SQRT_2;
    // Two parallel vertical planes, offset by `d` along their normal (s, −s, 0).
    let mk = |d: f64, anns: Vec<Annotation>| Plane {
        origin: [d * s, -d * s, 0.0],
        u: [s, s, 0.0],
        v: [0.0, 0.0, 1.0],
        roi: Rect {
            min: [-3.0, -3.0],
            max: [3.0, 3.0],
        },
        annotations: anns,
    };
    let frames = (0..2)
        .map(|i| Frame {
            time: i as f64,
            planes: vec![
                mk(
                    0.0,
                    vec![
                        Annotation {
                            class: 0,
                            polygons: vec![ring(2.0, 64), ring(1.0, 32)],
                        },
                        Annotation {
                            class: 1,
                            polygons: vec![],
                        },
                    ],
                ),
                mk(
                    1.0,
                    vec![Annotation {
                        class: 1,
                        polygons: vec![vec![[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]],
                    }],
                ),
            ],
        })
        .collect();
    let classes = vec![
        ClassInfo {
            name: "ring".into(),
            label: 1,
            color: None,
        },
        ClassInfo {
            name: "square".into(),
            label: 2,
            color: None,
        },
    ];
    Sequence::new(classes, frames).unwrap()
}

/// Signed distance of world point `x` from the first plane along the planes' normal.
fn offset(x: [f64; 3]) -> f64 {
    (x[0] - x[1]) * std::f64::consts::FRAC_1_SQRT_2
}

#[test]
fn same_seed_same_batch_different_stream_different_batch() {
    let seq = sequence();
    let index = SamplingIndex::new(&seq);
    let how = PlaneSampling::for_scene(4.0);
    let run = |stream| {
        let mut rng = SampleRng::new(3, stream);
        let (mut c, mut p) = (ContourBatch::default(), PlaneBatch::default());
        index.sample_contours(&mut rng, &[150, 150], &mut c);
        index.sample_planes(&mut rng, &[150, 150], &how, &mut p);
        (c, p)
    };
    assert_eq!(run(0), run(0));
    assert_ne!(run(0).0, run(1).0);
    let (c, p) = run(0);
    assert_eq!((c.len(), p.len()), (300, 300));
}

#[test]
fn contour_samples_lie_on_contours_with_outward_normals() {
    let seq = sequence();
    let index = SamplingIndex::new(&seq);
    let mut rng = SampleRng::new(1, 0);
    let mut c = ContourBatch::default();
    index.sample_contours(&mut rng, &[1000, 1000], &mut c);
    let mut per_class = [0usize; 2];
    for i in 0..c.len() {
        per_class[c.class[i] as usize] += 1;
        let x = c.xyz[i].map(f64::from);
        let n = c.normal[i].map(f64::from);
        assert!((n.iter().map(|v| v * v).sum::<f64>() - 1.0).abs() < 1e-5);
        // An in-plane vector combines u = (s, s, 0) and v = (0, 0, 1): its x and y are equal.
        assert!((n[0] - n[1]).abs() < 1e-5, "normal lies in the plane");
        let plane = usize::from(offset(x) > 0.5);
        assert!((offset(x) - plane as f64).abs() < 1e-5, "on a plane");
        assert_eq!(
            plane, c.class[i] as usize,
            "class 0 is outlined on plane 0, class 1 on plane 1"
        );
        let p = seq.frames()[0].planes[plane].to_plane(x);
        let step = |d: f64| {
            [
                p[0] + d * (n[0] + n[1]) * std::f64::consts::FRAC_1_SQRT_2,
                p[1] + d * n[2],
            ]
        };
        let sdf = |q| index.plane_sdf(plane, c.class[i] as usize, q).unwrap();
        assert!(sdf(p).abs() < 1e-5, "on the contour");
        assert!(sdf(step(0.01)) > 0.0 && sdf(step(-0.01)) < 0.0, "outward");
        assert!(c.t[i] == 0.0 || c.t[i] == 1.0);
    }
    assert_eq!(per_class, [1000, 1000], "each class gets its count");
}

#[test]
fn plane_targets_are_exact_and_absences_are_bounds() {
    let seq = sequence();
    let index = SamplingIndex::new(&seq);
    let mut rng = SampleRng::new(9, 4);
    let mut p = PlaneBatch::default();
    let how = PlaneSampling {
        near_fraction: 0.5,
        near_sigma: 0.05,
        near_width_fraction: 0.5,
        absent_fraction: 0.5,
    };
    index.sample_planes(&mut rng, &[2000, 2000], &how, &mut p);
    let mut absent = 0;
    for i in 0..p.len() {
        let x = p.xyz[i].map(f64::from);
        match p.kind[i] {
            PlaneTarget::LowerBound => {
                absent += 1;
                assert_eq!((p.class[i], p.target[i]), (1, 0.0));
                assert!(offset(x).abs() < 1e-5, "absence only on the first plane");
            }
            PlaneTarget::Sdf => {
                assert!((offset(x) - f64::from(p.class[i])).abs() < 1e-5);
                let q = [(x[0] + x[1]) * std::f64::consts::FRAC_1_SQRT_2, x[2]];
                let r = q[0].hypot(q[1]);
                if p.class[i] == 0 && (r - 1.5).abs() > 0.6 {
                    // Far from both polygonal rings the exact distance is close to the circles'.
                    let circle = if r > 1.5 { r - 2.0 } else { 1.0 - r };
                    assert!(
                        (f64::from(p.target[i]) - circle).abs() < 0.01,
                        "{r} {}",
                        p.target[i]
                    );
                }
            }
        }
    }
    // Class 1 has both kinds: half its samples are absences, i.e. about a quarter overall.
    assert!((800..1200).contains(&absent), "{absent}");
}

#[test]
fn space_time_samples_fill_the_box() {
    let seq = sequence();
    let b = seq.bounding_box();
    let mut rng = SampleRng::new(5, 5);
    let mut s = SpaceTimeBatch::default();
    sample_space_time(&mut rng, 1000, &b, seq.time_range(), &mut s);
    assert_eq!(s.xyz.len(), 1000);
    for (x, t) in s.xyz.iter().zip(&s.t) {
        for (k, &xk) in x.iter().enumerate() {
            let xk = f64::from(xk);
            assert!(xk >= b.min[k] - 1e-6 && xk <= b.max[k] + 1e-6);
        }
        assert!((0.0..=1.0).contains(t));
    }
    let cap = s.xyz.capacity();
    sample_space_time(&mut rng, 1000, &b, seq.time_range(), &mut s);
    assert_eq!(s.xyz.capacity(), cap, "buffers are reused");
}

/// The orientation term (Eq. 6) trusts the slices' in-plane normals: each must be the
/// projection of the exact shape's outward normal onto its plane, so its dot product with
/// the exact SDF's gradient is positive.
#[test]
fn contour_normals_point_out_of_the_exact_shapes() {
    let options = BenchmarkOptions {
        plane_resolution: 128,
        ..BenchmarkOptions::default()
    };
    for shape in Shape::ALL {
        let seq = slice_sequence(shape, &options).unwrap();
        let index = SamplingIndex::new(&seq);
        let mut batch = ContourBatch::default();
        let per_class = vec![4000 / seq.classes().len(); seq.classes().len()];
        index.sample_contours(&mut SampleRng::new(7, 0), &per_class, &mut batch);
        let mut worst = f64::INFINITY;
        let mut bad = 0;
        for i in 0..batch.len() {
            let x = batch.xyz[i].map(f64::from);
            let (t, k) = (f64::from(batch.t[i]), batch.class[i] as usize);
            let e = 1e-5;
            let grad: [f64; 3] = std::array::from_fn(|a| {
                let (mut p, mut m) = (x, x);
                p[a] += e;
                m[a] -= e;
                (shape.sdf(k, p, t) - shape.sdf(k, m, t)) / (2.0 * e)
            });
            let n = batch.normal[i].map(f64::from);
            let dot = (0..3).map(|a| grad[a] * n[a]).sum::<f64>();
            worst = worst.min(dot);
            bad += usize::from(dot <= 0.0);
        }
        eprintln!(
            "{}: worst dot {worst:.3}, {bad} of {} non-positive",
            shape.name(),
            batch.len()
        );
        assert_eq!(
            bad,
            0,
            "{}: {bad} normals point into the shape",
            shape.name()
        );
    }
}

#[test]
fn the_index_tells_its_progress_and_is_the_same_index() {
    // A benchmark sequence: enough annotations for several progress reports.
    let seq = slice_sequence(Shape::Chambers, &BenchmarkOptions::default()).unwrap();
    let mut reports = Vec::new();
    let index = SamplingIndex::with_progress(&seq, &mut |done, total| reports.push((done, total)));
    let total = reports.last().expect("a report").1;
    assert_eq!(reports.last(), Some(&(total, total)));
    assert!(reports.len() > 1, "{reports:?}");
    assert!(reports
        .windows(2)
        .all(|w| w[0].0 < w[1].0 && w[0].1 == w[1].1));
    // Built in chunks, the index is the one built at once: the same samples.
    let plain = SamplingIndex::new(&seq);
    let draw = |index: &SamplingIndex| {
        let mut c = ContourBatch::default();
        let counts = vec![200; seq.classes().len()];
        index.sample_contours(&mut SampleRng::new(5, 0), &counts, &mut c);
        c
    };
    assert_eq!(draw(&index), draw(&plain));
    assert_eq!(index.contour_lengths(), plain.contour_lengths());
}
