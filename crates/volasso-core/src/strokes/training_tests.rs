//! Tests of the training set: lassos to voxels per class, shared voxels, the cap.

use super::*;
use crate::slices::Axis;
use crate::strokes::{ClassStrokes, Lasso};

const DIMS: [usize; 3] = [40, 30, 20];

/// An axis-aligned rectangle of centres x0..=x1, y0..=y1 on z slice `z`.
fn rectangle(z: usize, x0: usize, y0: usize, x1: usize, y1: usize) -> Lasso {
    let (x0, y0, x1, y1) = (x0 as f64 - 0.5, y0 as f64 - 0.5, x1 as f64 + 0.5, y1 as f64 + 0.5);
    Lasso { axis: Axis::Z, slice: z, points: vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]] }
}

fn class(name: &str, strokes: Vec<Lasso>) -> ClassStrokes {
    ClassStrokes { name: name.into(), strokes }
}

#[test]
fn a_restricted_set_keeps_the_listed_voxels_and_never_empties_a_class() {
    let set = TrainingSet {
        classes: vec![
            ClassSamples::one_stroke("a".into(), vec![1, 2, 3, 4]),
            ClassSamples::one_stroke("b".into(), vec![10, 11]),
            ClassSamples::one_stroke("c".into(), vec![20, 21]),
        ],
        contested_voxels: 0,
    };
    let restricted = set.restricted(&[Some(&[2, 3, 99]), None, Some(&[5])]);
    let voxels: Vec<&[usize]> = restricted.classes.iter().map(|c| c.voxels.as_slice()).collect();
    assert_eq!(voxels, [&[2, 3][..], &[10, 11], &[20, 21]]);
    assert_eq!(restricted.classes[0].stroke_voxel_counts, vec![2]);
}

#[test]
fn voxels_claimed_by_two_classes_are_dropped_from_both() {
    let file = StrokesFile {
        classes: vec![
            // 10 x 10 (x, y 0..=9) and 5 x 10 (x 5..=9, y 2..=11): 110 voxels in all.
            class("bone", vec![rectangle(5, 0, 0, 9, 9), rectangle(5, 5, 2, 9, 11)]),
            // x 8..=11, y 0..=9: its columns 8 and 9 overlap bone's first stroke.
            class("soft tissue", vec![rectangle(5, 8, 0, 11, 9)]),
        ],
    };
    let set = TrainingSet::from_strokes(&file, DIMS).unwrap();
    assert_eq!(set.contested_voxels, 20);
    let bone = &set.classes[0];
    assert_eq!(bone.voxels.len(), 110 - 20);
    // The second stroke keeps only rows 10 and 11; the rest went to the first stroke.
    assert_eq!(bone.stroke_voxel_counts, vec![80, 10]);
    assert!(bone.voxels.windows(2).all(|w| w[0] < w[1]));
    let soft = &set.classes[1];
    assert_eq!(soft.voxels.len(), 40 - 20);
    for voxel in &soft.voxels {
        assert!(bone.voxels.binary_search(voxel).is_err());
        assert!([10, 11].contains(&(voxel % 40)));
    }
    // Within a class, an overlap counts once, for the first stroke.
    let first_stroke_voxel = 6 + 40 * (3 + 30 * 5);
    let position = bone.voxels.binary_search(&first_stroke_voxel).unwrap();
    assert_eq!(bone.stroke_of_voxel[position], 0);
    let (voxels, labels) = set.labelled_voxels();
    assert_eq!(voxels.len(), 110);
    assert_eq!(labels.iter().filter(|&&l| l == 2).count(), 20);
    assert_eq!(labels[0], 1);
}

#[test]
fn a_class_whose_lassos_select_nothing_is_an_error_naming_it() {
    let file = StrokesFile {
        classes: vec![
            class("bone", vec![rectangle(1, 0, 0, 3, 3)]),
            class("joint", vec![Lasso { axis: Axis::Y, slice: 2, points: vec![[1.0, 1.0], [2.0, 2.0]] }]),
        ],
    };
    let error = TrainingSet::from_strokes(&file, DIMS).unwrap_err();
    assert!(matches!(&error, StrokesError::EmptyClass { class, class_id: 2 } if class == "joint"));
    assert!(error.to_string().contains("'joint'"));
    let kept = TrainingSet::from_strokes_keeping_empty(&file, DIMS).unwrap();
    assert!(kept.classes[1].voxels.is_empty());
    assert_eq!(kept.classes[1].stroke_voxel_counts, vec![0]);
}

#[test]
fn a_loop_inside_another_class_s_loop_keeps_its_voxels() {
    let file = StrokesFile {
        classes: vec![
            class("bone", vec![rectangle(1, 0, 0, 9, 9)]),
            // Drawn inside bone's lasso: its voxels are marrow, bone keeps the rest.
            class("marrow", vec![rectangle(1, 2, 2, 4, 4)]),
        ],
    };
    let set = TrainingSet::from_strokes(&file, DIMS).unwrap();
    assert_eq!((set.classes[0].voxels.len(), set.classes[1].voxels.len(), set.contested_voxels), (91, 9, 0));
    assert!(set.classes[0].voxels.iter().all(|v| set.classes[1].voxels.binary_search(v).is_err()));
    assert_eq!(set.classes[0].stroke_voxel_counts, vec![91]);
}

#[test]
fn a_class_whose_voxels_another_class_all_selects_names_the_other_and_no_class_is_its_own_error() {
    let file = StrokesFile {
        classes: vec![
            class("bone", vec![rectangle(1, 0, 0, 9, 9)]),
            // Inside bone's lasso but too large to be drawn inside it (64 of 100 voxels):
            // every voxel is contested.
            class("marrow", vec![rectangle(1, 1, 1, 8, 8)]),
        ],
    };
    let error = TrainingSet::from_strokes(&file, DIMS).unwrap_err();
    assert!(
        matches!(&error, StrokesError::Overlapped { class, class_id: 2, other, other_id: 1 } if class == "marrow" && other == "bone"),
        "{error:?}"
    );
    let message = error.to_string();
    assert!(message.contains("class 2 'marrow' select only voxels that class 1 'bone' also selects"), "{message}");
    // Bone keeps voxels outside marrow: only marrow is refused.
    let kept = TrainingSet::from_strokes_keeping_empty(&file, DIMS).unwrap();
    assert_eq!((kept.classes[0].voxels.len(), kept.classes[1].voxels.len()), (100 - 64, 0));
    let none = TrainingSet::from_strokes(&StrokesFile::default(), DIMS).unwrap_err();
    assert!(matches!(none, StrokesError::NoClasses));
    assert_eq!(none.to_string(), "the strokes file defines no class");
}

#[test]
fn slices_outside_the_volume_and_too_many_classes_are_refused() {
    let file = StrokesFile { classes: vec![class("a", vec![rectangle(20, 0, 0, 3, 3)])] };
    assert!(matches!(
        TrainingSet::from_strokes(&file, DIMS),
        Err(StrokesError::SliceOutOfRange { slice: 20, slice_count: 20, .. })
    ));
    let many = StrokesFile { classes: (0..256).map(|k| class(&k.to_string(), vec![])).collect() };
    assert!(matches!(TrainingSet::from_strokes(&many, DIMS), Err(StrokesError::TooManyClasses { count: 256 })));
}

#[test]
fn a_cap_keeps_each_strokes_share_and_is_deterministic() {
    let file = StrokesFile {
        classes: vec![
            // 300 and 100 voxels on different slices, and a small class under the cap.
            class("bone", vec![rectangle(1, 0, 0, 29, 9), rectangle(2, 0, 0, 9, 9)]),
            class("air", vec![rectangle(3, 0, 0, 4, 4)]),
        ],
    };
    let set = TrainingSet::from_strokes(&file, DIMS).unwrap();
    let capped = set.capped(101, 7);
    let bone = &capped.classes[0];
    assert_eq!(bone.voxels.len(), 101);
    // 101 * 3/4 = 75.75, 101 / 4 = 25.25: the larger remainder gets the extra voxel.
    assert_eq!(bone.stroke_voxel_counts, vec![76, 25]);
    assert_eq!(bone.dropped_by_cap, 299);
    assert!(bone.voxels.windows(2).all(|w| w[0] < w[1]));
    assert!(bone.voxels.iter().all(|v| set.classes[0].voxels.binary_search(v).is_ok()));
    for (voxel, &stroke) in bone.voxels.iter().zip(&bone.stroke_of_voxel) {
        assert_eq!(voxel / (40 * 30), stroke as usize + 1);
    }
    assert_eq!(capped.classes[1], set.classes[1]);
    assert_eq!(set.capped(101, 7), capped);
    assert_ne!(set.capped(101, 8).classes[0].voxels, bone.voxels);
    assert_eq!(set.capped(1000, 7), set);
}

#[test]
fn a_cap_keeps_the_classes_in_the_order_of_their_sizes() {
    let file = StrokesFile {
        classes: vec![
            class("bone", vec![rectangle(1, 0, 0, 39, 24)]), // 1000 voxels
            class("joint", vec![rectangle(2, 0, 0, 24, 4)]), // 125
            class("marrow", vec![rectangle(3, 0, 0, 9, 0)]), // 10
        ],
    };
    let set = TrainingSet::from_strokes(&file, DIMS).unwrap();
    let counts: Vec<usize> = set.classes.iter().map(|c| c.voxels.len()).collect();
    assert_eq!(counts, vec![1000, 125, 10]);
    let capped = set.capped(100, 7);
    let kept: Vec<usize> = capped.classes.iter().map(|c| c.voxels.len()).collect();
    // An eighth of the largest class's voxels keeps 100 * (1/8)^(1/4), 59; 10 voxels are
    // within 100 * (1/100)^(1/4), 32.
    let expected = (100.0 * 0.125f64.powf(CAP_SIZE_EXPONENT)).round() as usize;
    assert_eq!(kept, vec![100, expected, 10]);
    assert!(expected < 100 && expected > 10);
    assert_eq!(capped.classes[1].dropped_by_cap, 125 - expected);
    assert_eq!(set.capped(1000, 7), set, "within the cap nothing changes");
    let one = set.capped(1, 7);
    assert!(one.classes.iter().all(|c| c.voxels.len() == 1), "every class keeps a voxel");
}

#[test]
fn largest_remainder_quotas_add_up_to_the_target() {
    assert_eq!(largest_remainder_quotas(&[1, 1, 1], 2), vec![1, 1, 0]);
    assert_eq!(largest_remainder_quotas(&[0, 10, 5], 6), vec![0, 4, 2]);
    assert_eq!(largest_remainder_quotas(&[0, 0], 3), vec![0, 0]);
    for target in 0..50 {
        let quotas = largest_remainder_quotas(&[7, 13, 29, 1], target);
        assert_eq!(quotas.iter().sum::<usize>(), target);
    }
}

/// Every class's voxels and strokes as the plain rule gives them: each stroke's voxels, the
/// first stroke of each voxel kept (how the set was built before loops were merged by runs).
fn first_stroke_of_each_voxel(strokes: &[Lasso]) -> Vec<(usize, u32)> {
    let mut tagged: Vec<(usize, u32)> = Vec::new();
    for (stroke, lasso) in strokes.iter().enumerate() {
        tagged.extend(lasso.selected_voxels(DIMS).into_iter().map(|voxel| (voxel, stroke as u32)));
    }
    tagged.sort_unstable();
    tagged.dedup_by_key(|&mut (voxel, _)| voxel);
    tagged
}

#[test]
fn overlapping_and_repeated_loops_give_each_voxel_to_its_first_stroke() {
    let mut rng = crate::rng::SplitMix64::new(5);
    for _ in 0..200 {
        let count = 1 + (rng.next_u64() % 6) as usize;
        let strokes: Vec<Lasso> = (0..count)
            .map(|_| {
                let axis = Axis::ALL[(rng.next_u64() % 3) as usize];
                let slice = (rng.next_u64() % 3) as usize;
                let points =
                    (0..3 + rng.next_u64() % 5).map(|_| [rng.next_f64() * 44.0 - 2.0, rng.next_f64() * 34.0 - 2.0]);
                Lasso { axis, slice, points: points.collect() }
            })
            .collect();
        // Repeat some strokes exactly, as a file of copies does.
        let mut with_copies = strokes.clone();
        with_copies.insert(0, strokes[count - 1].clone());
        with_copies.push(strokes[0].clone());
        for strokes in [strokes, with_copies] {
            let file = StrokesFile { classes: vec![class("a", strokes.clone())] };
            let set = TrainingSet::from_strokes_keeping_empty(&file, DIMS).unwrap();
            let expected = first_stroke_of_each_voxel(&strokes);
            let (voxels, stroke_of_voxel): (Vec<usize>, Vec<u32>) = expected.into_iter().unzip();
            assert_eq!(set.classes[0].voxels, voxels);
            assert_eq!(set.classes[0].stroke_of_voxel, stroke_of_voxel);
        }
    }
}

#[test]
fn twenty_thousand_copies_of_a_loop_cost_what_one_does() {
    // A full-slice loop on a 512 x 512 slice, 20,000 times: the copies are not rasterised.
    let dims = [512, 512, 2];
    let full =
        Lasso { axis: Axis::Z, slice: 1, points: vec![[-1.0, -1.0], [600.0, -1.0], [600.0, 600.0], [-1.0, 600.0]] };
    let file = StrokesFile { classes: vec![class("all", vec![full; 20_000])] };
    let started = std::time::Instant::now();
    let set = TrainingSet::from_strokes(&file, dims).unwrap();
    assert_eq!(set.classes[0].voxels.len(), 512 * 512);
    assert_eq!(set.classes[0].stroke_voxel_counts[0], 512 * 512);
    assert!(set.classes[0].stroke_voxel_counts[1..].iter().all(|&count| count == 0));
    // The cap splits its quota over the 20,000 strokes in one pass over the voxels.
    let capped = set.capped(256, 1);
    assert_eq!((capped.classes[0].voxels.len(), capped.classes[0].stroke_voxel_counts[0]), (256, 256));
    // Shifted copies are no exact repeats: merged run by run, they cost their rows.
    let shifted: Vec<Lasso> = (0..2_000)
        .map(|k| {
            let d = k as f64 * 1e-3;
            Lasso {
                axis: Axis::Z,
                slice: 1,
                points: vec![[-1.0 - d, -1.0], [600.0, -1.0], [600.0, 600.0], [-1.0, 600.0]],
            }
        })
        .collect();
    let set = TrainingSet::from_strokes(&StrokesFile { classes: vec![class("all", shifted)] }, dims).unwrap();
    assert_eq!(set.classes[0].voxels.len(), 512 * 512);
    assert!(started.elapsed().as_secs_f64() < 10.0, "{:?}", started.elapsed());
}

#[test]
fn a_loop_zig_zagging_across_every_row_is_refused_before_it_is_rasterised() {
    // 10^6 points, every edge from row 0 to row 511: 5 x 10^8 crossings.
    let dims = [512, 512, 1];
    let points: Vec<[f64; 2]> =
        (0..1_000_000).map(|k| [k as f64 * 512.0 / 1e6, if k % 2 == 0 { -0.5 } else { 511.5 }]).collect();
    let zig_zag = Lasso { axis: Axis::Z, slice: 0, points };
    let file = StrokesFile { classes: vec![class("zig", vec![zig_zag]), class("zag", vec![rectangle(0, 1, 1, 3, 3)])] };
    let started = std::time::Instant::now();
    let error = TrainingSet::from_strokes(&file, dims).unwrap_err();
    assert!(
        matches!(&error, StrokesError::TooManyCrossings { class, stroke: 0, crossings, limit: MAX_ROW_CROSSINGS }
            if class == "zig" && *crossings > MAX_ROW_CROSSINGS),
        "{error}"
    );
    assert!(started.elapsed().as_secs_f64() < 2.0, "{:?}", started.elapsed());
}
