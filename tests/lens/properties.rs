//! Property tests: the lens loader never panics on any input, and the batched tracer agrees
//! with the scalar reference on random rays.

use std::path::Path;

use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;
use realcam::batch::RayBatch;
use realcam::lens::first_order::FirstOrder;
use realcam::lens::focus::paraxial_film_distance;
use realcam::lens::io::bundled::{BUNDLED, load_lens};
use realcam::lens::pupil::{ExitPupil, PupilSampling};
use realcam::lens::trace::{Ray, Travel, normalize, trace};
use realcam::lens::trace_batch::{Kernel, trace_batch_with};
use realcam::lens::{LensFormat, LensSystem, Prescription};

/// Everything downstream of a successful parse must not panic either.
fn exercise(text: &str, format: Option<LensFormat>) {
    if let Ok(p) = Prescription::parse(text, Path::new("fuzz.dat"), format) {
        let system = LensSystem::new(&p.rows, None);
        if let Ok(fo) = FirstOrder::compute(&system)
            && let Ok(film) = paraxial_film_distance(&system, &fo, 3000.0)
        {
            let pupil = ExitPupil::compute(&system, film, 35.0, PupilSampling::Bounds);
            let _ = pupil.sample(1.0, 2.0, [0.5, 0.5]);
        }
    }
}

fn mutate(text: &str, edits: &[(usize, u8, u8)]) -> String {
    let mut bytes = text.as_bytes().to_vec();
    for &(position, kind, value) in edits {
        if bytes.is_empty() {
            break;
        }
        let i = position % bytes.len();
        match kind % 4 {
            0 => {
                bytes.remove(i);
            }
            1 => {
                let alphabet = b"0123456789.-e# \t\r\ninfa";
                bytes.insert(i, alphabet[value as usize % alphabet.len()]);
            }
            2 => bytes[i] = value,
            _ => {
                let line: Vec<u8> = bytes[i..]
                    .iter()
                    .take_while(|&&b| b != b'\n')
                    .copied()
                    .collect();
                bytes.splice(i..i, line);
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

proptest! {
    // Saved failing cases live beside this file (properties.proptest-regressions). proptest's
    // default would put them under tests/proptest-regressions/ now that main.rs sits here.
    #![proptest_config(ProptestConfig {
        cases: 200,
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        ..ProptestConfig::default()
    })]

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,400}") {
        exercise(&text, None);
        exercise(&text, Some(LensFormat::GapBefore));
    }

    #[test]
    fn numeric_tables_never_panic(rows in prop::collection::vec(prop::array::uniform4(-200.0f64..200.0), 0..14)) {
        let text: String = rows.iter().map(|r| format!("{} {} {} {}\n", r[0], r[1].abs(), 1.0 + r[2].abs() / 200.0, r[3].abs())).collect();
        exercise(&text, None);
        exercise(&text, Some(LensFormat::ThicknessAfter));
    }

    #[test]
    fn mutated_lens_files_never_panic(lens in 0usize..8, edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<u8>()), 1..12)) {
        let text = mutate(BUNDLED[lens].text, &edits);
        exercise(&text, None);
    }

    #[test]
    fn batched_tracing_agrees_with_the_scalar_reference(
        lens in 0usize..4,
        film in prop::array::uniform2(-15.0f64..15.0),
        aim in prop::array::uniform2(-1.0f64..1.0),
    ) {
        let p = load_lens(BUNDLED[lens].name, None).unwrap();
        let system = LensSystem::new(&p.rows, None);
        let fo = FirstOrder::compute(&system).unwrap();
        let film_z = system.rear_z() + fo.back_focal_length;
        let rear = system.rear_semi_aperture();
        let origin = [film[0], film[1], film_z];
        let direction = normalize([aim[0] * rear - film[0], aim[1] * rear - film[1], system.rear_z() - film_z]);
        let reference = trace(&system.f64s, Ray { origin, direction }, Travel::FilmToScene);
        for kernel in [Kernel::Simd, Kernel::AutoVectorised] {
            let mut batch = RayBatch::default();
            let f = |v: [f64; 3]| v.map(|x| x as f32);
            batch.push(f(origin), f(direction), 0, 0);
            trace_batch_with(&system.f32s, &mut batch, Travel::FilmToScene, kernel);
            if let (Ok(out), true) = (&reference, batch.alive[0]) {
                for k in 0..3 {
                    prop_assert!((batch.origin(0)[k] as f64 - out.origin[k]).abs() < 2e-3);
                    prop_assert!((batch.direction(0)[k] as f64 - out.direction[k]).abs() < 2e-4);
                }
            }
        }
    }
}
