//! The controller without a window or a GPU: lassos become classes and classification requests (also a
//! loop drawn inside another class's loop), undo takes them back, hiding a class restyles
//! without sending the labels again, and a saved session comes back on its volume.

use super::*;
use crate::chooser::library::LoadedVolume;
use std::sync::Arc;
use std::time::{Duration, Instant};
use volasso_core::phantom::{demo_foot_with, lassos_inside};
use volasso_core::preset::PresetClass;
use volasso_core::strokes::Lasso;
use volasso_core::transfer::TemplateType;

/// A small demo phantom opened as the chooser opens the demo, and lassos inside its soft
/// tissue and its bone.
fn demo() -> (LoadedVolume, Vec<Lasso>, Vec<Lasso>) {
    let phantom = demo_foot_with([96, 64, 48], 7).unwrap();
    let mut strokes = lassos_inside(&phantom, &[1, 2], 4, 2.5);
    let bone = strokes.classes.pop().unwrap().strokes;
    let soft = strokes.classes.pop().unwrap().strokes;
    (opened(phantom.volume), soft, bone)
}

/// `volume` as the chooser opens a scan that is not DICOM, in demo mode.
fn opened(volume: volasso_core::volume::Volume) -> LoadedVolume {
    crate::chooser::library::opened_for_tests(volume, volasso_core::preset::Modality::Unknown)
}

/// A controller that starts no thread and opens no GPU: its 3-D view takes requests (the
/// tests check what it is sent), its classifications run on the test's thread at the poll
/// after they are asked for, and its session is written as it is handed over.
fn inline(session_dir: Option<std::path::PathBuf>) -> Controller {
    Controller::with_workers(session_dir, crate::controller::ControllerWorkers::inline())
}

fn draw(controller: &mut Controller, lassos: &[Lasso]) -> Changed {
    let mut changed = Changed::default();
    for lasso in lassos {
        changed = controller.edit(|session| {
            session.add_lasso(lasso.clone());
            Ok(())
        });
    }
    changed
}

fn define(controller: &mut Controller) -> Changed {
    controller.edit(|session| session.define_class().map(|_| ()))
}

/// Polls until the classification comes back (a first look before it, and the survey of the
/// result before, are passed over).
fn classified(controller: &mut Controller) -> Changed {
    classified_after_first_looks(controller).0
}

/// Polls until the classification comes back; also how many first looks were shown before it.
fn classified_after_first_looks(controller: &mut Controller) -> (Changed, usize) {
    let started = Instant::now();
    let mut first_looks = 0;
    while started.elapsed() < Duration::from_secs(120) {
        let changed = controller.poll();
        if changed.status.as_deref().is_some_and(|status| status.starts_with("First look")) {
            assert!(changed.view && changed.classes, "a first look is shown: {changed:?}");
            first_looks += 1;
        } else if changed.status.is_some() {
            // A result or a failure (the survey of an earlier result, which may come between,
            // changes no status).
            return (changed, first_looks);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    panic!("no classification in two minutes");
}

fn requested_names(controller: &Controller) -> Vec<String> {
    let requested = controller.work.as_ref().and_then(|work| work.requested.as_ref());
    requested.map_or(Vec::new(), |strokes| strokes.classes.iter().map(|class| class.name.clone()).collect())
}

#[test]
fn lassos_become_classes_and_two_classes_are_classified() {
    let (loaded, soft, bone) = demo();
    let mut controller = inline(None);
    let opened = controller.open(Work::new(loaded), None);
    assert!(opened.classes && opened.view_cleared);
    assert!(!controller.jobs.busy());

    // One class has nothing to be told apart from: nothing is trained.
    let changed = draw(&mut controller, &soft);
    assert!(changed.classes);
    assert!(!controller.jobs.busy());
    define(&mut controller);
    assert_eq!(controller.work.as_ref().unwrap().session.classes.len(), 1);
    assert!(!controller.jobs.busy());

    // A lasso around something else: the pending lassos are the provisional second class.
    draw(&mut controller, &bone);
    assert!(controller.jobs.busy(), "two classes can be told apart: a classification is requested");
    assert_eq!(requested_names(&controller), ["Class 1", "Class 2"]);
    // Defining that class trains on the same lassos: the running job stands.
    define(&mut controller);
    assert!(controller.jobs.busy());

    let (changed, first_looks) = classified_after_first_looks(&mut controller);
    assert_eq!(first_looks, 1, "a coarse first look is shown before the exact result");
    assert!(changed.classes && changed.view, "{changed:?}");
    assert!(changed.status.as_deref().is_some_and(|status| status.starts_with("Classified in")));
    assert_eq!(controller.display_styles().map(|styles| styles.len()), Some(2));
    assert_eq!(controller.renderer.label_uploads(), 1);
}

#[test]
fn a_loop_drawn_inside_another_class_s_loop_is_a_class_of_its_own() {
    // A wide loop around a bone lasso, then that bone lasso inside it: the inner loop's voxels
    // are the second class's, so two classes can be told apart.
    let (loaded, _, bone) = demo();
    let inner = bone[0].clone();
    let count = inner.points.len() as f64;
    let centre = inner.points.iter().fold([0.0, 0.0], |sum, p| [sum[0] + p[0] / count, sum[1] + p[1] / count]);
    let around = |dx: f64, dy: f64| [centre[0] + dx, centre[1] + dy];
    let outer = Lasso {
        points: vec![around(-8.0, -8.0), around(8.0, -8.0), around(8.0, 8.0), around(-8.0, 8.0)],
        ..inner.clone()
    };
    let mut controller = inline(None);
    controller.open(Work::new(loaded), None);
    draw(&mut controller, &[outer]);
    define(&mut controller);
    draw(&mut controller, &[inner]);
    assert!(controller.jobs.busy(), "the inner loop is a class: a classification is requested");
    let changed = classified(&mut controller);
    assert!(changed.status.as_deref().is_some_and(|status| status.starts_with("Classified in")), "{changed:?}");
    assert_eq!(controller.display_styles().map(|styles| styles.len()), Some(2));
}

#[test]
fn undo_takes_back_lassos_and_the_classification_they_asked_for() {
    let (loaded, soft, bone) = demo();
    let mut controller = inline(None);
    controller.open(Work::new(loaded), None);
    draw(&mut controller, &soft);
    define(&mut controller);
    draw(&mut controller, &bone[..1]);
    assert!(controller.jobs.busy());

    let changed = controller.edit(|session| session.undo());
    assert!(changed.classes && changed.view_cleared);
    assert_eq!(changed.status.as_deref(), Some(""));
    let work = controller.work.as_ref().unwrap();
    assert!(work.session.pending.is_empty());
    assert!(work.requested.is_none() && !controller.jobs.busy(), "one class left: nothing to classify");

    // Undo of the definition gives the lassos back as pending.
    controller.edit(|session| session.undo());
    let work = controller.work.as_ref().unwrap();
    assert_eq!((work.session.classes.len(), work.session.pending.len()), (0, soft.len()));

    // With nothing left to undo the controller says why and changes nothing.
    while controller.work.as_ref().unwrap().session.can_undo() {
        controller.edit(|session| session.undo());
    }
    let changed = controller.edit(|session| session.undo());
    assert!(!changed.classes);
    assert!(changed.status.is_some_and(|status| !status.is_empty()));
}

#[test]
fn hiding_and_showing_a_class_restyles_without_sending_the_labels_again() {
    let (loaded, soft, bone) = demo();
    let mut controller = inline(None);
    controller.open(Work::new(loaded), None);
    draw(&mut controller, &soft);
    define(&mut controller);
    draw(&mut controller, &bone);
    define(&mut controller);
    classified(&mut controller);
    assert_eq!(controller.renderer.label_uploads(), 1);

    let hidden = controller.toggle_class(0);
    assert!(hidden.classes && hidden.view && !hidden.view_cleared);
    let styles = controller.display_styles().unwrap();
    assert!(!styles[0].visible && styles[1].visible);
    let shown = controller.toggle_class(0);
    assert!(shown.view);
    assert!(controller.display_styles().unwrap()[0].visible);
    let turned = controller.choose_template(HueTemplate::new(TemplateType::T, 40.0));
    assert!(turned.view);
    assert_eq!(controller.template().rotation_degrees, 40.0);
    assert_eq!(controller.renderer.label_uploads(), 1, "a restyle sends the class table alone");
    assert!(!controller.jobs.busy(), "a restyle never reclassifies");

    // A class that does not exist changes nothing.
    assert_eq!(controller.toggle_class(7), Changed::default());
}

#[test]
fn a_saved_session_comes_back_on_its_volume_only() {
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path().join("session");
    let (loaded, soft, bone) = demo();
    {
        let mut controller = inline(Some(dir.clone()));
        controller.open(Work::new(loaded), None);
        draw(&mut controller, &soft);
        define(&mut controller);
        draw(&mut controller, &bone);
        define(&mut controller);
        controller.choose_template(HueTemplate::new(TemplateType::L, 30.0));
        controller.toggle_class(1);
        controller.flush();
    }
    let saved = autosave::load(&dir).expect("the session was saved");
    assert_eq!(saved.volume, "demo");
    assert_eq!(saved.strokes.classes.len(), 2);

    // Restored on the same volume: classes, template, and a classification on its way.
    let (loaded, _, _) = demo();
    let mut restored = inline(Some(dir.clone()));
    restored.open(Work::new(loaded), Some(saved.clone()));
    let work = restored.work.as_ref().unwrap();
    let names: Vec<&str> = work.session.classes.iter().map(|class| class.name.as_str()).collect();
    assert_eq!(names, ["Class 1", "Class 2"]);
    assert_eq!(restored.template(), HueTemplate::new(TemplateType::L, 30.0));
    assert!(restored.jobs.busy(), "the restored classes are classified again");

    // A session saved for another volume is not applied to this one.
    let (loaded, _, _) = demo();
    let other = SavedSession { volume: "/data/other.nrrd".into(), ..saved };
    let mut fresh = inline(None);
    fresh.open(Work::new(loaded), Some(other));
    assert!(fresh.work.as_ref().unwrap().session.classes.is_empty());
    assert!(fresh.chosen_template.is_none());

    // The idle timeout forgets it, on disk too.
    restored.forget();
    assert!(restored.work.is_none());
    assert!(autosave::load(&dir).is_none());
}

/// A 32 x 32 x 16 volume of `value(x, y, z)` at `spacing_mm`, opened as the chooser opens one.
fn loaded(spacing_mm: [f64; 3], value: impl Fn(usize, usize, usize) -> f32) -> LoadedVolume {
    let dims = [32, 32, 16];
    let values: Vec<f32> =
        (0..dims[0] * dims[1] * dims[2]).map(|i| value(i % 32, (i / 32) % 32, i / (32 * 32))).collect();
    let volume =
        volasso_core::volume::Volume::from_f32(dims, spacing_mm, &values, std::path::Path::new("test.nrrd")).unwrap();
    opened(volume)
}

/// Deterministic noise in -8..8, so that no two lassoed voxels are alike.
fn noise(x: usize, y: usize, z: usize) -> f32 {
    (volasso_core::rng::hash64(7, (x + 32 * (y + 32 * z)) as u64) % 1600) as f32 / 100.0 - 8.0
}

/// Soft tissue (100) on the left half, bone (400) on the right, both with noise.
fn two_materials(x: usize, y: usize, z: usize) -> f32 {
    if x < 16 { 100.0 + noise(x, y, z) } else { 400.0 + noise(x, y, z) }
}

/// A square loop around x0..x0+6, y0..y0+6 on axial slice `z`.
fn square(z: usize, x0: f64, y0: f64) -> Lasso {
    Lasso {
        axis: volasso_core::slices::Axis::Z,
        slice: z,
        points: vec![[x0, y0], [x0 + 6.0, y0], [x0 + 6.0, y0 + 6.0], [x0, y0 + 6.0]],
    }
}

/// Opens `loaded`, defines a class from `first` and draws `second` (the provisional second
/// class, which starts a classification), and returns what its end changed.
fn classify_two(controller: &mut Controller, loaded: LoadedVolume, first: Lasso, second: Lasso) -> Changed {
    controller.open(Work::new(loaded), None);
    draw(controller, &[first]);
    define(controller);
    draw(controller, &[second]);
    assert!(controller.jobs.busy(), "two classes: a classification is requested");
    classified(controller)
}

/// A failed classification: a banner with the reason, no spinner, no result invented.
fn assert_failed(controller: &Controller, changed: &Changed, words: &[&str]) {
    let Failure::Failed(reason) = &changed.failure else { panic!("not a failure: {changed:?}") };
    for word in words {
        assert!(reason.contains(word), "'{word}' not in: {reason}");
    }
    assert_eq!(changed.status.as_deref(), Some("Classification failed"));
    assert!(failure_banner(reason).starts_with(FAILURE_BANNER_START));
    assert_eq!(controller.failure(), Some(reason.as_str()));
    assert!(!controller.jobs.busy());
    assert!(controller.work.as_ref().unwrap().classified.is_none());
    let hint = controller.view_hint();
    assert!(hint.contains("failed") && !hint.contains("Classifying"), "{hint}");
}

#[test]
fn lassoed_nan_voxels_fail_with_a_banner_that_names_the_voxel() {
    // A block of NaN under the first class's loop.
    let volume =
        loaded(
            [1.0; 3],
            |x, y, z| if (5..11).contains(&x) && (5..11).contains(&y) { f32::NAN } else { two_materials(x, y, z) },
        );
    let mut controller = inline(None);
    let changed = classify_two(&mut controller, volume, square(8, 4.5, 4.5), square(8, 20.5, 20.5));
    assert_failed(&controller, &changed, &["of class 'Class 1' is NaN", "cannot be trained on"]);
}

#[test]
fn values_near_the_float_limit_fail_with_a_banner_that_says_they_overflow() {
    // 3e38 beside -3e38 under the first loop: each value is finite, their difference is not.
    let huge = |x: usize, y: usize, z: usize| match x {
        0..8 => 3e38,
        8..16 => -3e38,
        _ => 400.0 + noise(x, y, z),
    };
    let mut controller = inline(None);
    let changed = classify_two(&mut controller, loaded([1.0; 3], huge), square(8, 4.5, 4.5), square(8, 20.5, 20.5));
    assert_failed(
        &controller,
        &changed,
        &["of class 'Class 1'", "is not a finite number", "overflow single precision"],
    );
}

#[test]
fn a_spacing_of_ten_to_the_minus_thirty_never_reaches_the_classifier() {
    // Its features would overflow single precision; the volume is refused when it opens (the
    // chooser's "Cannot open" card), so no classification of it can hang.
    let values = vec![0f32; 32 * 32 * 16];
    let refused =
        volasso_core::volume::Volume::from_f32([32, 32, 16], [1e-30; 3], &values, std::path::Path::new("t.nrrd"));
    assert!(refused.is_err());
}

#[test]
fn a_constant_volume_fails_with_a_banner_that_the_classes_cannot_be_told_apart() {
    let mut controller = inline(None);
    let changed =
        classify_two(&mut controller, loaded([1.0; 3], |_, _, _| 0.0), square(8, 4.5, 4.5), square(8, 20.5, 20.5));
    assert_failed(&controller, &changed, &["cannot be told apart", "is the volume constant?"]);
}

#[test]
fn a_failure_keeps_the_last_good_result_and_the_next_success_clears_its_banner() {
    // The left half flat at 100: two loops there are one and the same material.
    let volume = loaded([1.0; 3], |x, y, z| if x < 16 { 100.0 } else { 400.0 + noise(x, y, z) });
    let mut controller = inline(None);
    let changed = classify_two(&mut controller, volume, square(8, 4.5, 4.5), square(8, 20.5, 20.5));
    assert_eq!(changed.failure, Failure::Cleared, "{changed:?}");
    define(&mut controller);
    let good = controller.work.as_ref().unwrap().classified.as_ref().unwrap().labels.clone();

    // A third class on the same flat material as the first cannot be told apart from it.
    draw(&mut controller, &[square(3, 4.5, 20.5)]);
    assert!(controller.jobs.busy());
    let changed = classified(&mut controller);
    let Failure::Failed(reason) = &changed.failure else { panic!("not a failure: {changed:?}") };
    assert!(reason.contains("classes 'Class 1' and 'Class 3' cannot be told apart"), "{reason}");
    let kept = controller.work.as_ref().unwrap().classified.as_ref().expect("the last result stays");
    assert!(Arc::ptr_eq(&kept.labels, &good), "the last good labels are shown");
    assert_eq!(controller.view_hint(), "", "the 3-D view shows the last result, the banner says why it is old");
    assert!(!controller.jobs.busy());

    // Undo: the two classes again, classified anew; the failure's banner goes.
    controller.edit(|session| session.undo());
    assert!(controller.jobs.busy());
    let changed = classified(&mut controller);
    assert_eq!(changed.failure, Failure::Cleared, "{changed:?}");
    assert_eq!(controller.failure(), None);
}

/// `loaded` opened, its two classes drawn and defined, and their classification come back.
fn define_two_and_classify(controller: &mut Controller, loaded: &LoadedVolume, soft: &[Lasso], bone: &[Lasso]) {
    controller.open(Work::new(loaded.clone()), None);
    draw(controller, soft);
    define(controller);
    draw(controller, bone);
    define(controller);
    classified(controller);
}

/// Polls until the shown classification's survey has come back (what saving a preset needs).
fn surveyed(controller: &mut Controller) {
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(60) {
        controller.poll();
        if controller.work.as_ref().and_then(|work| work.classified.as_ref()).is_some_and(|c| c.guidance.is_some()) {
            return;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    panic!("no survey in a minute");
}

#[test]
fn a_preset_saved_from_one_classification_colours_the_scan_again_and_a_loop_refines_it() {
    let (loaded, soft, bone) = demo();
    let mut controller = inline(None);
    define_two_and_classify(&mut controller, &loaded, &soft, &bone);
    assert!(controller.preset_of_shown("early").is_err(), "the survey has not come back yet");
    surveyed(&mut controller);
    let preset = Arc::new(controller.preset_of_shown("foot").unwrap());
    assert_eq!(preset.class_names(), ["Class 1", "Class 2"]);
    let first = controller.work.as_ref().unwrap().classified.as_ref().unwrap().labels.clone();

    // The scan opened again and the preset applied: classified at once, without a loop.
    controller.open(Work::new(loaded), None);
    let changed = controller.apply_preset(preset.clone(), None);
    assert!(changed.classes && controller.jobs.busy(), "{changed:?}");
    let session = &controller.work.as_ref().unwrap().session;
    assert_eq!(session.classes.iter().map(|c| c.lassos.len()).collect::<Vec<_>>(), [0, 0]);
    let changed = classified(&mut controller);
    assert!(changed.status.as_deref().is_some_and(|s| s.starts_with("Classified in")), "{changed:?}");
    let again = controller.work.as_ref().unwrap().classified.as_ref().unwrap().labels.clone();
    let same = first.iter().zip(again.iter()).filter(|(a, b)| a == b).count();
    assert!(same * 1000 > first.len() * 995, "{same} of {}", first.len());

    // A loop of a new class on it: the preset's two and the new one are classified.
    draw(&mut controller, &soft[..1]);
    define(&mut controller);
    assert_eq!(requested_names(&controller), ["Class 1", "Class 2", "Class 3"]);
    classified(&mut controller);
    let refined = controller.work.as_ref().unwrap().classified.as_ref().unwrap();
    assert_eq!(refined.table.styles.len(), 3);
    assert!(refined.labels.contains(&3));

    // Deleting a preset's class leaves it out of the training.
    controller.edit(|session| session.delete_class(0));
    classified(&mut controller);
    assert_eq!(controller.work.as_ref().unwrap().classified.as_ref().unwrap().table.styles.len(), 2);

    // Undo (the delete, the class, its lasso, the application): no class is left.
    for _ in 0..4 {
        controller.edit(|session| session.undo());
    }
    let session = &controller.work.as_ref().unwrap().session;
    assert!(session.classes.is_empty(), "{:?}", session.classes);
    assert!(controller.applied_preset().is_none());
}

#[test]
fn a_preset_of_another_modality_is_refused_with_a_banner_and_changes_nothing() {
    let (loaded, soft, bone) = demo();
    let mut controller = inline(None);
    define_two_and_classify(&mut controller, &loaded, &soft, &bone);
    surveyed(&mut controller);
    let mut preset = controller.preset_of_shown("foot").unwrap();
    preset.modality = volasso_core::preset::Modality::Mr;
    let mut ct = loaded;
    ct.modality = volasso_core::preset::Modality::Ct;
    controller.open(Work::new(ct), None);
    let changed = controller.apply_preset(Arc::new(preset.clone()), None);
    let Failure::Failed(reason) = &changed.failure else { panic!("{changed:?}") };
    assert!(reason.contains("trained on MR and this scan is CT"), "{reason}");
    assert!(controller.work.as_ref().unwrap().session.classes.is_empty());
    assert!(!controller.jobs.busy());

    // More classes than the class bar holds: refused, not cut short.
    let mut many = preset;
    many.modality = volasso_core::preset::Modality::Ct;
    many.classes = (0..12).map(|k| PresetClass { name: format!("Class {k}"), style: None }).collect();
    let changed = controller.apply_preset(Arc::new(many), None);
    let Failure::Failed(reason) = &changed.failure else { panic!("{changed:?}") };
    assert!(reason.contains("has 12 classes and the class bar holds at most 8"), "{reason}");
    assert!(controller.work.as_ref().unwrap().session.classes.is_empty());
}

#[test]
fn a_session_names_its_preset_and_comes_back_with_it_or_says_it_is_gone() {
    let (loaded, soft, bone) = demo();
    let mut controller = inline(None);
    define_two_and_classify(&mut controller, &loaded, &soft, &bone);
    surveyed(&mut controller);
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("foot.volasso-preset");
    let preset = controller.preset_of_shown("foot").unwrap();
    preset.write(&path).unwrap();
    controller.open(Work::new(loaded.clone()), None);
    controller.apply_preset(Arc::new(preset), Some(path.clone()));
    draw(&mut controller, &soft[..1]);
    define(&mut controller);
    let saved = controller.saved_session().unwrap();
    assert_eq!(saved.look.preset.as_deref(), Some(path.as_path()));
    let record = crate::autosave::to_record(&saved).unwrap();
    let saved = crate::autosave::from_record(record).unwrap();

    let mut restored = inline(None);
    restored.open(Work::new(loaded.clone()), Some(saved.clone()));
    assert!(restored.work.as_ref().unwrap().preset.is_some());
    assert_eq!(requested_names(&restored), ["Class 1", "Class 2", "Class 3"]);
    let changed = classified(&mut restored);
    assert!(changed.status.as_deref().is_some_and(|s| s.starts_with("Classified in")), "{changed:?}");

    std::fs::remove_file(&path).unwrap();
    let mut orphan = inline(None);
    let changed = orphan.open(Work::new(loaded), Some(saved));
    let Failure::Failed(reason) = &changed.failure else { panic!("{changed:?}") };
    assert!(reason.contains("preset of the saved session cannot be read"), "{reason}");
    // The preset's classes had no lassos of their own: only the drawn one is left.
    assert_eq!(orphan.work.as_ref().unwrap().session.classes.len(), 1);
}
