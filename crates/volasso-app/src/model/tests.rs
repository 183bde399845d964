//! The app's model without a window, a thread or a GPU ([`Workers::none`]): a scan opened
//! from the chooser, loops drawn on its slices becoming classes and a classification asked
//! for, undo, a class hidden and shown, the clip plane, a result kept in the gallery and
//! opened again, the idle timeout clearing the session and starting the attract mode, and a
//! saved session restored at start.

use super::*;
use crate::clock::Clock;
use std::cell::Cell;
use std::rc::Rc;
use volasso_core::phantom::demo_foot_with;

/// A data folder holding a small demo phantom as `foot.nrrd`, and a session folder.
struct Folders {
    data: tempfile::TempDir,
    session: tempfile::TempDir,
}

fn folders() -> Folders {
    let data = tempfile::tempdir().unwrap();
    let volume = demo_foot_with([64, 48, 32], 7).unwrap().volume;
    volasso_core::volume::nrrd::write_volume(&data.path().join("foot.nrrd"), &volume, "test").unwrap();
    Folders { data, session: tempfile::tempdir().unwrap() }
}

/// A model over `folders` on a clock the test moves, with no thread and no GPU.
fn model(folders: &Folders, clock: &Rc<Cell<Duration>>) -> AppModel {
    let config = AppConfig {
        data_dir: Some(folders.data.path().to_path_buf()),
        session_dir: Some(folders.session.path().to_path_buf()),
        idle_timeout: Some(Duration::from_secs(120)),
        clock: Clock::Manual(clock.clone()),
        media_roots: Vec::new(),
        ..AppConfig::default()
    };
    let restore = match autosave::begin_restore(folders.session.path()) {
        autosave::Restore::Session(session) => Some(session),
        _ => None,
    };
    let workers = Workers::none(&config);
    AppModel::new(config, workers, restore, String::new())
}

/// Polls (a frame of the 3-D view measured at 64 x 48) until nothing is being worked on.
fn settle(model: &mut AppModel) -> Show {
    let mut show = Show::default();
    for _ in 0..200 {
        show = show.and(model.update(Intent::Poll(Measures { view_px: [64, 48], attract_side: 64 })));
        if model.is_idle() {
            return show;
        }
    }
    panic!("the model is still busy after 200 polls");
}

/// A closed square loop on `panel` from `low` to `high` (fractions of the picture).
fn draw_square(model: &mut AppModel, panel: usize, low: f32, high: f32) -> Show {
    let side = |k: usize| low + (high - low) * k as f32 / 10.0;
    let mut points: Vec<[f32; 2]> = (0..10).map(|k| [side(k), low]).collect();
    points.extend((0..10).map(|k| [high, side(k)]));
    points.extend((0..10).map(|k| [side(10 - k), high]));
    points.extend((0..=10).map(|k| [low, side(10 - k)]));
    let picture_px = [400.0, 300.0];
    model.update(Intent::Slice(SliceIntent::Down { panel, point: points[0], picture_px, ms: 0.0 }));
    for (k, &point) in points.iter().enumerate().skip(1) {
        model.update(Intent::Slice(SliceIntent::Move { panel, point, ms: 20.0 * k as f64 }));
    }
    let last = points[points.len() - 1];
    model.update(Intent::Slice(SliceIntent::Up { panel, point: last, ms: 20.0 * points.len() as f64 }))
}

/// The foot opened from the chooser's second card (the first is the built-in demo).
fn opened(folders: &Folders, clock: &Rc<Cell<Duration>>) -> AppModel {
    let mut model = model(folders, clock);
    let show = model.update(Intent::ShowChooser);
    assert!(show.screen && model.screen == Screen::Chooser);
    model.update(Intent::OpenVolume(1));
    assert!(model.opening.is_some());
    let show = settle(&mut model);
    assert_eq!(model.screen, Screen::Work);
    assert!(show.screen && show.work, "{show:?}");
    model
}

/// Two classes: a loop in the middle of the slices (bone and marrow) and one near an edge.
fn two_classes(model: &mut AppModel) {
    let show = draw_square(model, 0, 0.45, 0.55);
    assert!(show.work, "a lasso drawn changes the work screen: {show:?}");
    model.update(Intent::DefineClass);
    draw_square(model, 0, 0.15, 0.25);
    model.update(Intent::DefineClass);
    settle(model);
}

fn class_count(model: &AppModel) -> usize {
    model.ctl.work.as_ref().map_or(0, |work| work.session.classes.len())
}

fn requested_classes(model: &AppModel) -> usize {
    model.ctl.work.as_ref().and_then(|work| work.requested.as_ref()).map_or(0, |strokes| strokes.classes.len())
}

#[test]
fn loops_become_classes_a_classification_is_asked_for_and_undo_takes_a_loop_back() {
    let (folders, clock) = (folders(), Rc::new(Cell::new(Duration::ZERO)));
    let mut model = opened(&folders, &clock);
    let show = draw_square(&mut model, 0, 0.45, 0.55);
    assert!(show.work);
    assert_eq!(model.ctl.work.as_ref().unwrap().session.pending.len(), 1);
    // One class cannot be classified yet.
    assert_eq!(requested_classes(&model), 0);
    model.update(Intent::DefineClass);
    draw_square(&mut model, 0, 0.15, 0.25);
    assert_eq!(class_count(&model), 1);
    assert_eq!(requested_classes(&model), 2, "the pending loop is classified as a second class");
    settle(&mut model);
    assert!(model.ctl.work.as_ref().unwrap().classified.is_some());
    assert!(model.view_picture.is_some(), "the 3-D view asked for a frame and shows it");

    // Undo: one class is left, nothing to classify, and the 3-D view is emptied.
    let show = model.update(Intent::Undo);
    assert!(show.work && show.view_picture, "{show:?}");
    let work = model.ctl.work.as_ref().unwrap();
    assert!(work.session.pending.is_empty() && work.classified.is_none());
    assert_eq!(requested_classes(&model), 0);
    assert!(model.view_picture.is_none());
}

#[test]
fn a_class_hidden_and_shown_again_and_the_clip_plane_on_and_off() {
    let (folders, clock) = (folders(), Rc::new(Cell::new(Duration::ZERO)));
    let mut model = opened(&folders, &clock);
    two_classes(&mut model);
    let visible = |model: &AppModel| model.ctl.work.as_ref().unwrap().session.classes[0].visible;
    assert!(model.update(Intent::ToggleClass(0)).work);
    assert!(!visible(&model));
    model.update(Intent::ToggleClass(0));
    assert!(visible(&model));

    let show = model.update(Intent::View(ViewIntent::ToggleClip));
    assert!(show.clipping && show.panels.iter().all(|&panel| panel), "{show:?}");
    assert!(model.ctl.look.clip.is_some());
    model.update(Intent::View(ViewIntent::ToggleClip));
    assert!(model.ctl.look.clip.is_none());
}

#[test]
fn a_kept_result_opens_again_with_its_classes_and_visibility() {
    let (folders, clock) = (folders(), Rc::new(Cell::new(Duration::ZERO)));
    let mut model = opened(&folders, &clock);
    two_classes(&mut model);
    model.update(Intent::ToggleClass(1));
    settle(&mut model);
    model.update(Intent::SaveResult);
    let show = settle(&mut model);
    assert!(show.results, "the saved result joins the chooser's cards: {show:?}");
    assert_eq!(model.gallery.listed().len(), 1, "{}", model.status);

    // Another scan (the demo) is opened, then the kept result.
    model.update(Intent::OpenVolume(0));
    settle(&mut model);
    assert_eq!(class_count(&model), 0);
    model.update(Intent::OpenResult(0));
    settle(&mut model);
    let work = model.ctl.work.as_ref().unwrap();
    assert_eq!(work.loaded.source.name(), "foot.nrrd");
    let visible: Vec<bool> = work.session.classes.iter().map(|class| class.visible).collect();
    assert_eq!(visible, [true, false]);
}

#[test]
fn the_idle_timeout_clears_the_session_and_starts_the_attract_mode() {
    let (folders, clock) = (folders(), Rc::new(Cell::new(Duration::ZERO)));
    let mut model = opened(&folders, &clock);
    draw_square(&mut model, 0, 0.45, 0.55);
    settle(&mut model);
    // A touch a minute later starts the count again: two minutes after it, not before.
    clock.set(Duration::from_secs(60));
    model.update(Intent::DismissBanner);
    clock.set(Duration::from_secs(170));
    settle(&mut model);
    assert_eq!(model.screen, Screen::Work);
    clock.set(Duration::from_secs(181));
    let show = model.update(Intent::Poll(Measures { view_px: [64, 48], attract_side: 64 }));
    assert_eq!(model.screen, Screen::Start);
    assert!(model.ctl.work.is_none() && model.view_picture.is_none());
    assert!(show.screen && show.view_picture);
    assert_eq!(show.attract, Some(AttractShow::Begin), "the turntable starts");
    assert_ne!(model.attract.describe(), "off");
    // Leaving the start screen ends it.
    assert_eq!(model.update(Intent::ShowChooser).attract, Some(AttractShow::End));
    assert_eq!(model.attract.describe(), "off");
}

#[test]
fn a_saved_session_opens_its_scan_with_its_classes_at_start() {
    let (folders, clock) = (folders(), Rc::new(Cell::new(Duration::ZERO)));
    {
        let mut model = opened(&folders, &clock);
        two_classes(&mut model);
        model.ctl.flush();
    }
    let mut model = model(&folders, &clock);
    assert!(model.restore.is_some(), "the autosaved session is read at start");
    let show = model.start_up();
    assert!(show.status && model.opening.is_some());
    settle(&mut model);
    assert_eq!(model.screen, Screen::Work);
    assert_eq!(class_count(&model), 2);
    assert!(!model.restore_unconfirmed, "the restore marker goes once it opened and classified");
}
