//! The metadata a trained model records is its run record: it parses without a problem, every
//! key the trainer writes is there with the run's values, and emitting it again gives the
//! file's text byte for byte.

use dynaslice_model::{RunRecord, SampleRecord};
use dynaslice_sequence::{Sequence, Space, TimeUnit, Units};
use dynaslice_synth::{BenchmarkOptions, Shape};
use dynaslice_train::fit::{fit, InputRecord, Quiet};
use dynaslice_train::spec::TrainSpec;

#[test]
fn the_trainers_metadata_is_a_run_record() {
    let synth = dynaslice_synth::slice_sequence(
        Shape::Chambers,
        &BenchmarkOptions {
            plane_resolution: 24,
            ..BenchmarkOptions::default()
        },
    )
    .unwrap();
    // The input's colours for two of its classes: the record keeps those, by label.
    let mut classes = synth.classes().to_vec();
    classes[0].color = Some([0xe6, 0x19, 0x4b]);
    classes[2].color = Some([0, 0, 255]);
    let seq = Sequence::new(classes, synth.frames().to_vec()).unwrap();
    let spec = TrainSpec {
        steps: Some(3),
        seed: Some(11),
        threads: Some(1),
        widths: Some(vec![8, 8]),
        class_weights: Some(vec![2.0; seq.classes().len()]),
        ..TrainSpec::default()
    };
    let input = InputRecord {
        description: "chambers + more".into(),
        frames: "0:4:2".into(),
        reading: Some("labels=1,2; planes=slices".into()),
        space: Space::Lps,
        units: Units::Millimetres,
        time_unit: TimeUnit::Milliseconds,
    };
    let trained = fit(&seq, &spec, &input, None, &mut Quiet).unwrap();
    let model = trained.bytes.model().unwrap();
    let text = model.metadata();
    let record = RunRecord::parse(text).unwrap_or_else(|e| panic!("{e} in\n{text}"));
    assert_eq!(
        record.emit(),
        text,
        "the emitter reproduces the file's text"
    );
    assert!(record.other.is_empty(), "unknown lines: {:?}", record.other);
    for key in RunRecord::KEYS {
        // A run without a time budget plans no schedule; these classes are not nested; the
        // benchmark's planes are not all parallel, so no plane band, no extent and no
        // samples between neighbouring planes.
        let absent = matches!(
            *key,
            "planned_steps" | "nesting" | "plane_band" | "extent_margin" | "between_pairs"
        );
        assert_eq!(
            text.lines().any(|l| l.starts_with(&format!("{key} = "))),
            !absent,
            "{key} in\n{text}"
        );
    }
    assert_eq!(record.input.as_deref(), Some("chambers + more"));
    assert_eq!(record.frames.as_deref(), Some("0:4:2"));
    assert_eq!(record.reading.as_deref(), Some("labels=1,2; planes=slices"));
    assert_eq!(record.space, Some(Space::Lps));
    assert_eq!(record.units, Some(Units::Millimetres));
    assert_eq!(record.time_unit, Some(TimeUnit::Milliseconds));
    assert_eq!(record.widths, Some(vec![8, 8]));
    assert_eq!((record.steps, record.steps_done), (Some(3), Some(3)));
    assert_eq!((record.seed, record.threads), (Some(11), Some(1)));
    assert_eq!(record.omega_0, Some(spec.options(1.0, None).omega_0));
    assert_eq!(record.class_weights, spec.class_weights);
    let counts = spec.counts();
    assert_eq!(
        record.samples,
        Some(SampleRecord {
            contour_per_class: counts.contour_per_class,
            plane_per_class: counts.plane_per_class,
            budget_classes: counts.budget_classes,
            min_per_class: counts.min_per_class,
            space_time: counts.space,
        })
    );
    let (a, c) = (seq.classes()[0].label, seq.classes()[2].label);
    assert_eq!(
        record.class_colors,
        Some(vec![(a, [0xe6, 0x19, 0x4b]), (c, [0, 0, 255])])
    );
    assert!(record.final_loss.is_some_and(f64::is_finite));
}

/// A run on parallel planes records its plane band, the one `spatial_bound` gives its data
/// (`--no-plane-band` records none), the margin of its classes' extents, half the planes'
/// spacing in world units, and its classes' pairs of neighbouring planes that both outline
/// them (the sampler's count).
#[test]
fn a_run_on_parallel_planes_records_its_plane_band() {
    use dynaslice_train::data_sampler::domain_for;
    use dynaslice_train::spatial_bound::plane_band;
    let seq = dynaslice_synth::slice_sequence(
        Shape::Blob,
        &BenchmarkOptions {
            planes: Some((0, 4)),
            plane_resolution: 16,
            volume_resolution: 8,
            ..BenchmarkOptions::default()
        },
    )
    .unwrap();
    let input = InputRecord {
        description: "parallel".into(),
        frames: "0:".into(),
        reading: None,
        space: Space::Ras,
        units: Units::Millimetres,
        time_unit: TimeUnit::Plain,
    };
    let record = |no_plane_band: bool| {
        let spec = TrainSpec {
            steps: Some(2),
            threads: Some(1),
            widths: Some(vec![8, 8]),
            no_plane_band,
            ..TrainSpec::default()
        };
        let trained = fit(&seq, &spec, &input, None, &mut Quiet).unwrap();
        RunRecord::of(&trained.bytes.model().unwrap()).unwrap()
    };
    let factor = TrainSpec::default().temporal_factor();
    let band = plane_band(&seq, &domain_for(&seq), factor, true).unwrap();
    let banded = record(false);
    assert_eq!(banded.plane_band, Some(band.max));
    assert_eq!(record(true).plane_band, None);
    let planes = &seq.frames()[0].planes;
    let normal = planes[0].normal();
    let along =
        |p: &dynaslice_sequence::Plane| -> f64 { (0..3).map(|i| p.origin[i] * normal[i]).sum() };
    let spacing = (along(&planes[1]) - along(&planes[0])).abs();
    let margin = f64::from(banded.extent_margin.unwrap());
    assert!(
        (margin - 0.5 * spacing).abs() < 1e-4 * spacing,
        "{margin} against half of {spacing}"
    );
    let sampler = dynaslice_train::data_sampler::DataSampler::new(
        &seq,
        domain_for(&seq),
        TrainSpec::default().counts(),
    );
    let pairs: Vec<u32> = sampler
        .neighbour_pairs()
        .iter()
        .map(|&n| n as u32)
        .collect();
    assert!(pairs.iter().all(|&n| n > 0), "{pairs:?}");
    assert_eq!(banded.between_pairs, Some(pairs));
}
