use super::*;

/// The gate of the bands `drawn` gives.
fn gate_of(drawn: &DrawnLassos) -> IntensityGate {
    IntensityGate::from_bands(drawn.bands().expect("every class has a finite value"))
}

fn gate(bands: &[(f32, f32)]) -> IntensityGate {
    IntensityGate::from_bands(bands.iter().map(|&(low, high)| Band { low, high }).collect())
}

#[test]
fn a_band_alone_allows_its_class_and_overlaps_allow_both() {
    let gate = gate(&[(-1000.0, -900.0), (0.0, 100.0), (80.0, 1500.0)]);
    assert_eq!(gate.allowed(-950.0), 0b001);
    assert_eq!(gate.allowed(50.0), 0b010);
    assert_eq!(gate.allowed(90.0), 0b110);
    assert_eq!(gate.allowed(1000.0), 0b100);
}

#[test]
fn between_bands_the_neighbours_on_both_sides_and_beyond_them_the_outermost() {
    let gate = gate(&[(-1000.0, -900.0), (0.0, 100.0), (200.0, 300.0)]);
    assert_eq!(gate.allowed(-500.0), 0b011, "between air and soft tissue");
    assert_eq!(gate.allowed(150.0), 0b110);
    assert_eq!(gate.allowed(2000.0), 0b100, "brighter than every band");
    assert_eq!(gate.allowed(-3000.0), 0b001, "darker than every band");
    assert_eq!(gate.allowed(f32::NAN), 0);
}

#[test]
fn the_tabulated_gate_answers_as_its_bands_do() {
    let mut rng = crate::rng::SplitMix64::new(9);
    for _ in 0..200 {
        let bands: Vec<(f32, f32)> = (0..1 + rng.below(6))
            .map(|_| {
                let low = rng.below(200) as f32 - 100.0;
                (low, low + rng.below(80) as f32)
            })
            .collect();
        let gate = gate(&bands);
        for intensity in (-120..=200).map(|v| v as f32).chain([0.5, -99.25, 1e9, -1e9]) {
            assert_eq!(gate.allowed(intensity), allowed_by_bands(&gate.bands, intensity), "{bands:?} at {intensity}");
        }
    }
}

#[test]
fn beyond_every_band_the_classes_whose_bands_end_near_the_outermost_end_are_allowed() {
    // A thin joint's band reaches past a bone drawn over its marrow: the cortex, brighter
    // than both, is left to the vote of the two, never to soft tissue.
    let foot = gate(&[(0.0, 90.0), (200.0, 370.0), (200.0, 450.0)]);
    assert_eq!(foot.allowed(1300.0), 0b110);
    // A leaky vessel band overlaps the bone's lower half only: the cortex stays the bone's.
    let torso = gate(&[(200.0, 290.0), (240.0, 820.0)]);
    assert_eq!(torso.allowed(1300.0), 0b10);
    // Darker than every band, the same from below.
    let dark = gate(&[(-1000.0, -900.0), (-980.0, -700.0), (0.0, 100.0)]);
    assert_eq!(dark.allowed(-1100.0), 0b011);
    assert_eq!(dark.drawn_range(), Some(Band { low: -1000.0, high: 100.0 }));
    assert_eq!(Band { low: -1000.0, high: 100.0 }.clamp(1300.0), 100.0);
}

#[test]
fn an_open_gate_allows_every_class() {
    let gate = IntensityGate::open(3);
    assert_eq!(gate.allowed(12.0), 0b111);
    assert_eq!(IntensityGate::open(70).every_class(), ClassSet::MAX);
    let contains = crate::classify::class_set_contains;
    assert!(contains(ClassSet::MAX, 65) && contains(0b10, 1) && !contains(0b10, 0));
}

const DIMS: [usize; 3] = [40, 40, 3];

/// A class of the square `x`, `y` on plane 1, one stroke.
fn square(x: std::ops::Range<usize>, y: std::ops::Range<usize>) -> crate::strokes::ClassSamples {
    let mut voxels: Vec<usize> = y.flat_map(|y| x.clone().map(move |x| x + DIMS[0] * (y + DIMS[1]))).collect();
    voxels.sort_unstable();
    crate::strokes::ClassSamples::one_stroke("class".into(), voxels)
}

/// Muscle (40) wherever `tissue` gives no value at (x, y), its value elsewhere, the same
/// through every plane, and a little noise (0 to 6).
fn muscle_with(tissue: impl Fn(usize, usize) -> Option<f32>) -> Volume {
    let values: Vec<f32> = (0..DIMS.iter().product())
        .map(|index: usize| tissue(index % DIMS[0], index / DIMS[0] % DIMS[1]).unwrap_or(40.0) + (index % 7) as f32)
        .collect();
    Volume::from_f32(DIMS, [1.0; 3], &values, std::path::Path::new("t")).unwrap()
}

/// Muscle (40) everywhere, a bone of `marrow` inside x, y 10..20 with a cortex of `cortex`
/// one voxel thick around it, and a little noise.
fn bone_in_muscle(marrow: f32, cortex: f32) -> Volume {
    muscle_with(|x, y| {
        let edge = x == 10 || x == 19 || y == 10 || y == 19;
        ((10..20).contains(&x) && (10..20).contains(&y)).then_some(if edge { cortex } else { marrow })
    })
}

#[test]
fn a_lasso_core_is_two_voxels_inside_its_edge() {
    let class = square(5..16, 5..16);
    let core = lasso_core(&class.voxels, DIMS);
    assert_eq!(core, square(7..14, 7..14).voxels);
    assert!(lasso_core(&square(0..3, 0..40).voxels, DIMS).is_empty());
}

#[test]
fn a_loop_that_leaked_into_its_neighbour_takes_its_band_from_its_core() {
    // The bone's loop (x, y 8..22) reaches two voxels into the muscle around the bone: a
    // third of its voxels. Its band comes from its core: muscle is muscle's alone.
    let volume = bone_in_muscle(1000.0, 1000.0);
    let set = TrainingSet { classes: vec![square(25..36, 25..36), square(8..22, 8..22)], contested_voxels: 0 };
    let gate = gate_of(&DrawnLassos::read(&volume, &set));
    let [muscle, bone] = gate.bands() else { panic!("{gate:?}") };
    assert!(bone.low > 900.0 && muscle.holds(43.0), "{gate:?}");
    assert_eq!(gate.allowed(43.0), 0b01);
    // The same loop with the muscle's class not drawn: the rim is nobody else's, and the
    // bone keeps it.
    let alone = TrainingSet { classes: vec![square(8..22, 8..22)], contested_voxels: 0 };
    assert!(gate_of(&DrawnLassos::read(&volume, &alone)).bands()[0].holds(43.0));
}

#[test]
fn a_rim_that_differs_from_the_core_but_is_nobody_elses_stays_in_the_band() {
    // A clean loop just inside the bone (x, y 10..20): its rim is the bright cortex, its
    // core the marrow; the cortex is no other class's, so the band keeps both.
    let volume = bone_in_muscle(300.0, 1400.0);
    let set = TrainingSet { classes: vec![square(25..36, 25..36), square(10..20, 10..20)], contested_voxels: 0 };
    let gate = gate_of(&DrawnLassos::read(&volume, &set));
    let bone = gate.bands()[1];
    assert!(bone.holds(303.0) && bone.holds(1403.0), "{gate:?}");
    // A loop too small for a core of MIN_CORE_VOXELS keeps all its voxels too.
    let small = TrainingSet { classes: vec![square(25..36, 25..36), square(8..15, 8..15)], contested_voxels: 0 };
    assert!(lasso_core(&small.classes[1].voxels, DIMS).len() < MIN_CORE_VOXELS);
    assert!(gate_of(&DrawnLassos::read(&volume, &small)).bands()[1].holds(43.0));
}

#[test]
fn a_rim_nearer_its_own_core_than_the_other_class_s_is_not_a_leak() {
    // A thin layer's loop drawn cleanly (x, y 10..20): its core 300, its edge 260 where the
    // scan blurs it into its darker surroundings. Another class drawn over a wide range of
    // values (a ramp from 100 up to 290 at x 25..36, its core band about 130 to 275, its
    // middle about 200) holds 260 too. 260 is nearer the layer's own core than the other
    // class's middle: the rim is the layer's own, not a finger's leak, and the band keeps it.
    let volume = muscle_with(|x, y| {
        if (10..20).contains(&x) && (10..20).contains(&y) {
            let edge = x == 10 || x == 19 || y == 10 || y == 19;
            Some(if edge { 260.0 } else { 300.0 })
        } else {
            ((25..36).contains(&x) && (25..36).contains(&y)).then(|| (100.0 + 20.0 * (x - 25) as f32).min(290.0))
        }
    });
    let set = TrainingSet { classes: vec![square(25..36, 25..36), square(10..20, 10..20)], contested_voxels: 0 };
    let drawn = DrawnLassos::read(&volume, &set);
    let gate = gate_of(&drawn);
    let [wide, layer] = gate.bands() else { panic!("{gate:?}") };
    assert!(wide.holds(263.0) && layer.holds(263.0) && layer.holds(303.0), "{gate:?}");
    assert_eq!(drawn.training_voxels(), vec![None, None]);
}

#[test]
fn a_loop_whose_core_lies_over_another_class_is_judged_by_the_bands_alone() {
    // Another class drawn over a ramp of 300 to 1100 (x 25..36; core quartiles about 540, 700
    // and 860). A loop (x, y 10..20) whose core, 620, lies between those quartiles: its core is
    // over that class, as a joint's off-centre loop over the bone's marrow. Its rim (560) is
    // nearer its own core than the other's middle, yet the core cannot speak for the class:
    // the rim inside the other's core band is a leak, and the loop takes its core's band.
    let volume = muscle_with(|x, y| {
        if (10..20).contains(&x) && (10..20).contains(&y) {
            let edge = x <= 11 || x >= 18 || y <= 11 || y >= 18;
            Some(if edge { 560.0 } else { 620.0 })
        } else {
            ((25..36).contains(&x) && (25..36).contains(&y)).then(|| 300.0 + 80.0 * (x - 25) as f32)
        }
    });
    let set = TrainingSet { classes: vec![square(25..36, 25..36), square(10..20, 10..20)], contested_voxels: 0 };
    let drawn = DrawnLassos::read(&volume, &set);
    let gate = gate_of(&drawn);
    let [ramp, lasso] = gate.bands() else { panic!("{gate:?}") };
    assert!(ramp.holds(563.0) && !lasso.holds(563.0), "{gate:?}");
    let core = square(12..18, 12..18).voxels;
    assert_eq!(drawn.training_voxels(), vec![None, Some(core.as_slice())]);
}

#[test]
fn stray_voxels_do_not_widen_a_band_and_the_margin_follows_the_spread() {
    // 100 values 0..99 and one stray voxel at -1000: the 2 % quantile ignores it.
    let mut values: Vec<f64> = (0..100).map(f64::from).chain([-1000.0]).collect();
    let band = band_of(&mut values).unwrap();
    let spread = (95.0 - 5.0) / 3.29;
    assert!((band.low as f64 - (1.0 - BAND_MARGIN * spread)).abs() < 1.5, "{band:?}");
    assert!((band.high as f64 - (97.0 + BAND_MARGIN * spread)).abs() < 1.5, "{band:?}");
    assert_eq!(band_of(&mut []), None);
    let mut flat = vec![7.0; 10];
    assert_eq!(band_of(&mut flat), Some(Band { low: 7.0, high: 7.0 }));
}

#[test]
fn a_leaked_loop_trains_on_its_core_where_the_core_stands_for_it() {
    let volume = bone_in_muscle(1000.0, 1000.0);
    let muscle = square(25..36, 25..36);
    // The bone's loop two voxels into the muscle: it trains on its core, the bone.
    let leaked = TrainingSet { classes: vec![muscle.clone(), square(8..22, 8..22)], contested_voxels: 0 };
    let core = square(10..20, 10..20).voxels;
    assert_eq!(DrawnLassos::read(&volume, &leaked).training_voxels(), vec![None, Some(core.as_slice())]);
    // A clean loop trains on all of it.
    let clean = TrainingSet { classes: vec![muscle.clone(), square(10..20, 10..20)], contested_voxels: 0 };
    assert_eq!(DrawnLassos::read(&volume, &clean).training_voxels(), vec![None, None]);
    // A leaked class whose core is under CORE_TRAINING_SHARE of its voxels (thin strips of
    // muscle beside the loop, too thin for a core) trains on all of them.
    let mut voxels = square(8..22, 8..22).voxels;
    voxels.extend(square(0..40, 30..33).voxels);
    voxels.extend(square(0..40, 36..38).voxels);
    voxels.sort_unstable();
    voxels.dedup();
    let thin = crate::strokes::ClassSamples::one_stroke("bone".into(), voxels);
    let core_share = lasso_core(&thin.voxels, DIMS).len() as f64 / thin.voxels.len() as f64;
    assert!(core_share < CORE_TRAINING_SHARE, "{core_share}");
    let strips = TrainingSet { classes: vec![muscle, thin], contested_voxels: 0 };
    assert_eq!(DrawnLassos::read(&volume, &strips).training_voxels(), vec![None, None]);
}

/// Medium (40) everywhere; a cell (100) at x, y 5..25 with a nucleus (200) at x, y 10..20
/// inside it; a second nucleus at x, y 29..39; through every plane, with a little noise.
fn cell_with_nucleus() -> Volume {
    muscle_with(|x, y| {
        let within = |range: std::ops::Range<usize>| range.contains(&x) && range.contains(&y);
        if within(10..20) || within(29..39) { Some(200.0) } else { within(5..25).then_some(100.0) }
    })
}

#[test]
fn a_clean_loop_sets_aside_the_voxels_it_encloses_of_another_drawn_class() {
    let volume = cell_with_nucleus();
    let voxel = |x: usize, y: usize| x + DIMS[0] * (y + DIMS[1]);
    let (medium, cell, nucleus) = (square(0..4, 0..40), square(5..25, 5..25), square(29..39, 29..39));
    let set = TrainingSet { classes: vec![medium.clone(), cell.clone(), nucleus], contested_voxels: 0 };
    let drawn = DrawnLassos::read(&volume, &set);
    let training = drawn.training_voxels();
    let Some(cell_voxels) = training[1] else { panic!("the cell's loop encloses the nucleus: {training:?}") };
    assert!(cell_voxels.binary_search(&voxel(15, 15)).is_err(), "the nucleus's centre is set aside");
    assert!(cell_voxels.binary_search(&voxel(7, 7)).is_ok() && cell_voxels.binary_search(&voxel(22, 15)).is_ok());
    assert!(cell_voxels.len() >= cell.voxels.len() - 100, "only nucleus voxels go");
    assert_eq!((training[0], training[2]), (None, None));
    // The user drew them as the cell: every lassoed voxel keeps its class.
    assert_eq!(drawn.decided_voxels(), vec![None, None, None]);
    // The nucleus's centre is the nucleus's alone; the cell's band, taken without the voxels
    // set aside, reaches less far into it.
    let gate = gate_of(&drawn);
    let whole =
        DrawnLassos::read(&volume, &TrainingSet { classes: vec![medium.clone(), cell.clone()], contested_voxels: 0 });
    assert!(gate.bands()[1].high < gate_of(&whole).bands()[1].high, "{gate:?}");
    // Without a nucleus class drawn, the bright voxels are nobody else's: the cell keeps them.
    assert_eq!(whole.training_voxels(), vec![None, None]);
}

#[test]
fn a_class_drawn_on_a_structure_too_small_for_a_core_does_not_stop_a_loop_setting_aside_what_it_encloses() {
    // The cells' failure: a granule's loop of 15 voxels, bright (240) with an edge blurred down
    // to the medium's values (40, 90, 140), has no core; its band's middle half holds the
    // cell's values, which must not read as the cell's loop lying over the granules.
    let granule = |x: usize, y: usize| {
        let edge = y == 2 && x < 33;
        ((30..35).contains(&x) && (2..5).contains(&y)).then(|| if edge { 40.0 + 50.0 * (x - 30) as f32 } else { 240.0 })
    };
    let volume = muscle_with(|x, y| {
        let within = |range: std::ops::Range<usize>| range.contains(&x) && range.contains(&y);
        granule(x, y).or(if within(10..20) || within(29..39) { Some(200.0) } else { within(5..25).then_some(100.0) })
    });
    let classes = vec![square(0..4, 0..40), square(5..25, 5..25), square(29..39, 29..39), square(30..35, 2..5)];
    let drawn = DrawnLassos::read(&volume, &TrainingSet { classes, contested_voxels: 0 });
    let training = drawn.training_voxels();
    let Some(cell_voxels) = training[1] else { panic!("the cell's loop encloses the nucleus: {training:?}") };
    assert!(cell_voxels.binary_search(&(15 + DIMS[0] * (15 + DIMS[1]))).is_err(), "the nucleus's centre is set aside");
}

#[test]
fn a_loop_that_lies_mostly_over_another_class_keeps_its_voxels() {
    // A loop around the nucleus that reaches far over the cell (as a finger's loop around a
    // small structure does): its median is the cell's, so which voxels are its own is unknown.
    let volume = cell_with_nucleus();
    let set = TrainingSet {
        classes: vec![square(0..4, 0..40), square(5..25, 21..25), square(6..24, 6..24)],
        contested_voxels: 0,
    };
    let drawn = DrawnLassos::read(&volume, &set);
    assert_eq!(drawn.training_voxels()[2], None);
}
