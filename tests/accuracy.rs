//! Regression test of the accuracy harness (`volasso accuracy --quick`) on small
//! phantoms with known truth and simulated lassos, at seeds never used for tuning.

use std::sync::atomic::AtomicBool;
use volasso::accuracy::{self, Case, Method, PhantomKind, UserModel, report};
use volasso::segmentation::{self, Refinement, SegmentationOptions};

#[test]
fn the_fine_multiscale_forest_beats_a_forest_on_the_paper_features_and_is_not_below_the_svm() {
    let cases: Vec<Case> = PhantomKind::ALL.iter().map(|&kind| Case { kind, seed: 5 }).collect();
    let methods = [Method::SvmPaper5, Method::ForestPaper5, Method::ForestMultiscaleFine];
    // Full-size phantoms: at the quick size (half the voxels per axis) the thinnest
    // structures are one or two voxels wide, lassos there hold a handful of voxels, and the
    // comparison says more about the phantom than about the methods.
    let outcomes = accuracy::evaluate(&cases, &methods, &UserModel::default(), false, |outcome| {
        println!("{}", report::row(outcome));
    })
    .unwrap();
    print!("{}", report::summary(&outcomes, &methods));
    let mean = |method| report::mean_macro_dice(&outcomes, method, None).unwrap();
    let (default, forest) = (mean(Method::ForestMultiscaleFine), mean(Method::ForestPaper5));
    assert!(default >= forest + MARGIN_OVER_FOREST, "default {default:.3} vs forest on paper5 {forest:.3}");
    for case in &cases {
        let macro_dice =
            |method| outcomes.iter().find(|o| o.case == *case && o.method == method).map(|o| o.macro_dice()).unwrap();
        let (default, svm) = (macro_dice(Method::ForestMultiscaleFine), macro_dice(Method::SvmPaper5));
        assert!(default >= svm - SVM_TOLERANCE, "{}: default {default:.3} vs svm {svm:.3}", case.kind.name());
    }
}

/// Measured on the full-size phantoms at seed 5 (release build): the fine multi-scale forest
/// 0.788, the forest on the paper's features 0.719 (mean macro Dice); the fine forest is above
/// the plain SVM on every case, by 0.043 to 0.132. Everything is seeded, so the margins guard
/// against regressions, not against chance.
const MARGIN_OVER_FOREST: f64 = 0.04;
const SVM_TOLERANCE: f64 = 0.0;

#[test]
fn the_default_coarse_to_fine_labels_match_exact_evaluation_closely() {
    let phantom = PhantomKind::Vessels.generate(PhantomKind::Vessels.dims(true), 7).unwrap();
    let training = accuracy::draw_training(&phantom, &UserModel::default(), 7);
    let options = SegmentationOptions::default();
    let segmenter = segmentation::train(&phantom.volume, &training, &options).unwrap();
    let label = |refinement| {
        segmentation::label_volume(&phantom.volume, &segmenter, refinement, &|_| {}, &AtomicBool::new(false))
            .unwrap()
            .labels
    };
    let (exact, refined) = (label(Refinement::Exact), label(Refinement::CoarseToFine));
    let differing = exact.iter().zip(&refined).filter(|(a, b)| a != b).count();
    let fraction = differing as f64 / exact.len() as f64;
    println!("coarse-to-fine differs from exact on {differing} voxels ({fraction:.5})");
    assert!(fraction < 0.01, "{fraction}");
}
