//! Attract mode: after the idle timeout the start screen plays a slow turntable of the newest
//! kept result (gallery.rs) whose scan is there, or of the demo with its benchmark lassos when
//! the gallery has none, under "Touch anywhere to start"; any touch starts as before.
//!
//! An idle stand runs all day, so the turn costs almost nothing: the result opens, classifies
//! and renders [`FRAMES`] frames of one turn once, at the size the start screen shows them, on
//! a controller of its own (no autosave, its own render thread), which is then dropped with
//! its GPU device and volume. The turn is then replayed from those pictures at
//! [`FRAMES_PER_SECOND`]; nothing is rendered again while it plays, and nothing at all once
//! the start screen is left. The pictures are kept for the next idle period: when it shows
//! the same result at the same size they play at once, with nothing opened or rendered.
//!
//! Never: touches the user's session, the autosave or the work screen's 3-D view.

use super::controller::Controller;
use super::gallery::{self, Listed};
use super::ui::{AppWindow, Session};
use super::view3d::RenderReply;
use super::worker::{Report, Task, Threaded, Ticket, Worker};
use super::{
    State, Work,
    autosave::{SavedLook, SavedSession},
};
use crate::chooser::library::{self, LoadedVolume, OpenError, VolumeSource};
use slint::ComponentHandle;
use std::cell::RefCell;
use std::rc::{Rc, Weak};
use std::sync::Arc;
use std::time::Duration;
use volasso_core::render::Camera;
use volasso_core::strokes::StrokesFile;

/// Pictures in one turn (12 degrees apart).
pub const FRAMES: usize = 30;

/// How fast the turn plays: a turn takes `FRAMES / FRAMES_PER_SECOND` = 15 s.
pub const FRAMES_PER_SECOND: u64 = 2;

/// The largest side of a turntable picture, in pixels: a start screen is looked at from afar.
pub const MAX_SIDE: u32 = 480;

/// How often loading and rendering are looked after while the turn is prepared.
const PREPARING_TICK: Duration = Duration::from_millis(50);

/// The demo's lassos (the benchmark's), for a stand whose gallery is empty.
const DEMO_STROKES: &str = include_str!("../../../benches/strokes/demo-foot.strokes.json");

type Shared = Rc<RefCell<State>>;

/// What the turntable shows.
#[derive(Clone, Debug)]
struct Showing {
    session: SavedSession,
    name: String,
    camera: Camera,
    visible: Vec<bool>,
}

enum Phase {
    Off,
    Loading {
        showing: Showing,
        loader: Box<dyn Worker<VolumeSource, Result<Box<LoadedVolume>, OpenError>>>,
    },
    Rendering {
        showing: Showing,
        ctl: Box<Controller>,
        frames: Vec<slint::Image>,
        size: [u32; 2],
        awaited: Option<u64>,
    },
    Playing {
        frames: Vec<slint::Image>,
        next: usize,
        name: String,
        /// What was turned, at which size ([`turn_key`]).
        key: String,
    },
}

/// One prepared turn, kept while the app is not on the start screen.
struct Turn {
    key: String,
    frames: Vec<slint::Image>,
    name: String,
}

/// The attract mode's part of the app's state.
pub(super) struct Attract {
    phase: Phase,
    timer: slint::Timer,
    /// The last turn prepared, played again when the same result is shown at the same size.
    last_turn: Option<Turn>,
}

impl Default for Attract {
    fn default() -> Self {
        Attract { phase: Phase::Off, timer: slint::Timer::default(), last_turn: None }
    }
}

impl Attract {
    /// The turn is being prepared (replay's `wait-idle` waits for it).
    pub(super) fn busy(&self) -> bool {
        matches!(self.phase, Phase::Loading { .. } | Phase::Rendering { .. })
    }

    /// `off`, `loading`, `rendering` or `playing` (replay's `expect attract`).
    pub(super) fn describe(&self) -> &'static str {
        match self.phase {
            Phase::Off => "off",
            Phase::Loading { .. } => "loading",
            Phase::Rendering { .. } => "rendering",
            Phase::Playing { .. } => "playing",
        }
    }
}

/// The idle timeout brought the start screen back: the turntable starts.
pub(super) fn begin(window: &AppWindow, state: &Shared) {
    if !matches!(state.borrow().attract.phase, Phase::Off) {
        return;
    }
    let Some(showing) = what_to_show(&state.borrow()) else { return };
    let key = turn_key(&showing, picture_side(window));
    let kept = state.borrow_mut().attract.last_turn.take_if(|turn| turn.key == key);
    if let Some(turn) = kept {
        log::info!("attract mode: the turntable of {} again, as prepared before", turn.name);
        let phase = Phase::Playing { frames: turn.frames, next: 1, name: turn.name, key: turn.key };
        state.borrow_mut().attract.phase = phase;
        play(window, state);
        return;
    }
    let options = state.borrow().config.open_options.clone();
    let source = VolumeSource::from_key(&showing.session.volume);
    let task: Task<VolumeSource, Result<Box<LoadedVolume>, OpenError>> =
        Arc::new(move |source, _: &Ticket, report: &Report<'_, Result<Box<LoadedVolume>, OpenError>>| {
            report(library::guarded(&source, || library::load(&source, &options)).map(Box::new))
        });
    let mut loader: Box<dyn Worker<_, _>> = Box::new(Threaded::new("attract", task));
    loader.send(source);
    log::info!("attract mode: a turntable of {}", showing.name);
    let mut state_ref = state.borrow_mut();
    state_ref.attract.phase = Phase::Loading { showing, loader };
    let (weak_window, weak_state) = (window.as_weak(), Rc::downgrade(state));
    state_ref.attract.timer.start(slint::TimerMode::Repeated, PREPARING_TICK, move || tick(&weak_window, &weak_state));
    drop(state_ref);
    window.global::<Session>().set_attract_caption("".into());
}

/// The start screen is left: the turntable stops, and what it held goes.
pub(super) fn end(window: &AppWindow, state: &Shared) {
    let phase = {
        let mut state = state.borrow_mut();
        state.attract.timer.stop();
        std::mem::replace(&mut state.attract.phase, Phase::Off)
    };
    match phase {
        Phase::Rendering { mut ctl, .. } => ctl.jobs.cancel(),
        Phase::Playing { frames, name, key, .. } => {
            state.borrow_mut().attract.last_turn = Some(Turn { key, frames, name })
        }
        Phase::Off | Phase::Loading { .. } => {}
    }
    let session = window.global::<Session>();
    session.set_attracting(false);
    session.set_attract_picture(slint::Image::default());
}

/// The newest kept result whose scan is there, else the demo with its benchmark lassos.
fn what_to_show(state: &State) -> Option<Showing> {
    let listed = state.config.data_dir.as_deref().map(gallery::list).unwrap_or_default();
    let kept = listed.into_iter().find_map(|listed| match listed {
        Listed::Entry { entry, .. } if !entry.volume_missing() => Some(entry),
        _ => None,
    });
    if let Some(entry) = kept {
        return Some(Showing {
            name: format!("Saved result: {}", entry.volume_name),
            camera: entry.camera,
            visible: entry.visible,
            session: entry.session,
        });
    }
    let strokes = match StrokesFile::parse(DEMO_STROKES) {
        Ok(strokes) => strokes,
        Err(error) => {
            log::error!("attract mode: the demo's lassos do not parse: {error}");
            return None;
        }
    };
    Some(Showing {
        session: SavedSession {
            volume: VolumeSource::Demo.key(),
            template: String::new(),
            rotation_degrees: 0.0,
            strokes,
            look: SavedLook::default(),
        },
        name: VolumeSource::Demo.name(),
        camera: Camera::default(),
        visible: Vec::new(),
    })
}

fn tick(window: &slint::Weak<AppWindow>, state: &Weak<RefCell<State>>) {
    let (Some(window), Some(state)) = (window.upgrade(), state.upgrade()) else { return };
    let phase = std::mem::replace(&mut state.borrow_mut().attract.phase, Phase::Off);
    let was_rendering = matches!(phase, Phase::Rendering { .. });
    let next = match phase {
        Phase::Off => Phase::Off,
        Phase::Loading { showing, mut loader } => match loader.poll().map(|delivery| delivery.output) {
            None if loader.ended_silently().is_some() => stopped("the loader stopped"),
            None => Phase::Loading { showing, loader },
            Some(Err(error)) => stopped(&format!("cannot open {}: {error}", showing.name)),
            Some(Ok(loaded)) => {
                let mut ctl = Box::new(Controller::new(None));
                ctl.open(Work::new(*loaded), Some(showing.session.clone()));
                for (index, shown) in showing.visible.iter().enumerate() {
                    if !shown {
                        ctl.toggle_class(index);
                    }
                }
                let side = picture_side(&window);
                Phase::Rendering { showing, ctl, frames: Vec::new(), size: [side, side], awaited: None }
            }
        },
        Phase::Rendering { showing, ctl, frames, size, awaited } => render(showing, ctl, frames, size, awaited),
        Phase::Playing { frames, next, name, key } => {
            let session = window.global::<Session>();
            if let Some(frame) = frames.get(next) {
                session.set_attract_picture(frame.clone());
            }
            Phase::Playing { next: (next + 1) % frames.len().max(1), frames, name, key }
        }
    };
    let started_playing = was_rendering && matches!(next, Phase::Playing { .. });
    let stopped_now = matches!(next, Phase::Off);
    let mut state_ref = state.borrow_mut();
    state_ref.attract.phase = next;
    if stopped_now {
        state_ref.attract.timer.stop();
    }
    drop(state_ref);
    if started_playing {
        play(&window, &state);
    }
}

/// The turn in the `Playing` phase starts: its timer, its first picture and its caption.
fn play(window: &AppWindow, state: &Shared) {
    let state_ref = state.borrow_mut();
    let (first, caption) = match &state_ref.attract.phase {
        Phase::Playing { frames, name, .. } => (frames.first().cloned(), name.clone()),
        _ => return,
    };
    let (weak_window, weak_state) = (window.as_weak(), Rc::downgrade(state));
    let interval = Duration::from_millis(1000 / FRAMES_PER_SECOND);
    state_ref.attract.timer.start(slint::TimerMode::Repeated, interval, move || tick(&weak_window, &weak_state));
    drop(state_ref);
    let session = window.global::<Session>();
    session.set_attracting(true);
    session.set_attract_caption(caption.into());
    if let Some(first) = first {
        session.set_attract_picture(first);
    }
}

/// The side of a turntable picture in pixels: the start screen's picture at its scale.
fn picture_side(window: &AppWindow) -> u32 {
    let scale = window.window().scale_factor();
    ((window.global::<Session>().get_attract_size() * scale).round() as u32).clamp(64, MAX_SIDE)
}

/// What a turn shows and at which size: equal keys, equal pictures. The scan's file or folder
/// is named with its length and modification time, so a scan replaced at the same path (a
/// series received again) is rendered anew, never shown from the old pictures.
fn turn_key(showing: &Showing, side: u32) -> String {
    let path = match VolumeSource::from_key(&showing.session.volume) {
        VolumeSource::Demo => None,
        VolumeSource::Path(path) => Some(path),
        VolumeSource::Series { folder, .. } => Some(folder),
    };
    let stamp = path.and_then(|path| std::fs::metadata(path).ok()).map(|meta| (meta.len(), meta.modified().ok()));
    format!("{side} {stamp:?} {showing:?}")
}

fn stopped(reason: &str) -> Phase {
    log::warn!("attract mode: {reason}; the start screen stays still");
    Phase::Off
}

/// Classification, then one turn's pictures one after another; the controller goes once the
/// turn is whole.
fn render(
    showing: Showing,
    mut ctl: Box<Controller>,
    mut frames: Vec<slint::Image>,
    size: [u32; 2],
    mut awaited: Option<u64>,
) -> Phase {
    let changed = ctl.poll();
    let classified = ctl.work.as_ref().is_some_and(|work| work.classified.is_some());
    if let Some(status) = changed.status.filter(|_| !classified) {
        return stopped(&format!("the classification failed: {status}"));
    }
    if !classified {
        return Phase::Rendering { showing, ctl, frames, size, awaited };
    }
    while let Some(reply) = ctl.renderer.poll() {
        match reply {
            RenderReply::Failed(error) => return stopped(&error.to_string()),
            RenderReply::Picture(picture) if Some(picture.id) == awaited && picture.whole => {
                let image = &picture.image;
                let buffer = slint::SharedPixelBuffer::<slint::Rgba8Pixel>::clone_from_slice(
                    image.as_raw(),
                    image.width(),
                    image.height(),
                );
                frames.push(slint::Image::from_rgba8(buffer));
                awaited = None;
            }
            RenderReply::Picture(_) => {}
        }
    }
    if frames.len() == FRAMES {
        ctl.jobs.cancel();
        drop(ctl);
        log::info!("attract mode: {} pictures of {} ready", frames.len(), showing.name);
        let key = turn_key(&showing, size[0]);
        return Phase::Playing { frames, next: 1, name: showing.name, key };
    }
    if awaited.is_none() {
        let mut camera = showing.camera;
        camera.azimuth_degrees += 360.0 * frames.len() as f32 / FRAMES as f32;
        awaited = Some(ctl.renderer.request_whole_frame(camera, size));
    }
    Phase::Rendering { showing, ctl, frames, size, awaited }
}
