//! Synthetic benchmark end to end: slices lie on the analytic zero sets, the protocol's frame and
//! plane counts, exact native round trip, and the ground-truth NIfTI through the NIfTI reader.

use dynaslice_data::nifti::read;
use dynaslice_data::reslice::ResliceOptions;
use dynaslice_data::LabelTable;
use dynaslice_sequence::native;
use dynaslice_synth::{label_volume, slice_sequence, write_benchmark, BenchmarkOptions, Shape};

/// Coarse settings keep the test fast; the protocol's counts are unchanged.
fn small() -> BenchmarkOptions {
    BenchmarkOptions {
        plane_resolution: 64,
        volume_resolution: 24,
        ..Default::default()
    }
}

#[test]
fn slices_follow_the_protocol_and_lie_on_the_zero_set() {
    for shape in Shape::ALL {
        let o = small();
        let seq = slice_sequence(shape, &o).unwrap_or_else(|e| panic!("{}: {e}", shape.name()));
        assert_eq!(seq.frames().len(), 10, "every 4th of 37");
        assert_eq!(seq.frames()[9].time, 1.0);
        let planes = if shape.is_thin() { 70 } else { 30 };
        assert!(seq.frames().iter().all(|f| f.planes.len() == planes));
        assert_eq!(seq.classes().len(), shape.class_names().len());
        // Linear interpolation of an exact SDF on a grid of step h is accurate to O(h²)·curvature.
        let h = 2.0 / 63.0;
        for f in seq.frames().iter().step_by(3) {
            for plane in &f.planes {
                for a in &plane.annotations {
                    for p in a.polygons.iter().flatten() {
                        let d = shape.sdf(a.class, plane.to_world(*p), f.time);
                        assert!(
                            d.abs() < 0.25 * h,
                            "{} class {}: {d}",
                            shape.name(),
                            a.class
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn chambers_volume_has_three_disjoint_labels() {
    let o = BenchmarkOptions {
        timesteps: 5,
        ..small()
    };
    let v = label_volume(Shape::Chambers, &o);
    assert_eq!((v.dims, v.frames), ([24; 3], 5));
    for f in 0..5 {
        let frame = &v.labels[f * 24 * 24 * 24..(f + 1) * 24 * 24 * 24];
        for label in 1..=3 {
            assert!(frame.contains(&label), "frame {f} label {label}");
        }
    }
}

#[test]
fn written_benchmark_reads_back_through_both_paths() {
    let dir = tempfile::tempdir().unwrap();
    let o = small();
    let files = write_benchmark(dir.path(), &[Shape::Chambers], &o).unwrap();
    assert_eq!(files.len(), 1);
    let slices = native::read(&files[0].slices).unwrap();
    assert_eq!(slices, slice_sequence(Shape::Chambers, &o).unwrap());
    let names = LabelTable::read(&files[0].labels).unwrap();
    let opts = ResliceOptions {
        frames: "0:37:4".parse().unwrap(),
        rotated: 6,
        ..Default::default()
    };
    let resliced = read(&files[0].truth, &opts, &names).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(resliced.classes(), slices.classes());
    let times: Vec<f64> = resliced.frames().iter().map(|f| f.time).collect();
    let want: Vec<f64> = slices.frames().iter().map(|f| f.time).collect();
    for (a, b) in times.iter().zip(&want) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
}
