//! Attract mode: after the idle timeout the start screen plays a slow turntable of the newest
//! kept result (gallery/) whose scan is there, or of the demo with its benchmark lassos when
//! the gallery has none, under "Touch anywhere to start"; any touch starts as before.
//!
//! An idle stand runs all day, so the turn costs almost nothing: the result opens, classifies
//! and renders [`FRAMES`] frames of one turn once, at the size the start screen shows them, on
//! a controller of its own (no autosave, its own renderer), which is then dropped with its GPU
//! device and volume. The turn is then replayed from those pictures at [`FRAMES_PER_SECOND`];
//! nothing is rendered again while it plays, and nothing at all once the start screen is left.
//! The pictures are kept for the next idle period: when it shows the same result at the same
//! size they play at once, with nothing opened or rendered.
//!
//! A Slint-free model ([`Attract`]) ticked by the app's poll on the app's clock; view.rs puts
//! what it shows on the start screen. Its loader and controller come from [`Workers`], so its
//! tests run without a thread or a GPU.
//!
//! Never: touches the user's session, the autosave or the work screen's 3-D view.

pub(crate) mod app;
pub(crate) mod view;

use crate::Work;
use crate::autosave::{SavedLook, SavedSession};
use crate::chooser::library::{self, LoadedVolume, OpenError, VolumeSource};
use crate::controller::Controller;
use crate::gallery::{self, Listed};
use crate::view3d::RenderReply;
use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;
use volasso_core::render::Camera;
use volasso_core::strokes::StrokesFile;
use volasso_core::volume::OpenOptions;
use volasso_core::volume::dicom::PatientShown;

/// Pictures in one turn (12 degrees apart).
pub const FRAMES: usize = 30;

/// How fast the turn plays: a turn takes `FRAMES / FRAMES_PER_SECOND` = 15 s.
pub const FRAMES_PER_SECOND: u64 = 2;

/// The largest side of a turntable picture, in pixels: a start screen is looked at from afar.
pub const MAX_SIDE: u32 = 480;

/// The demo's lassos (the benchmark's), for a stand whose gallery is empty.
const DEMO_STROKES: &str = include_str!("../../../../benches/strokes/demo-foot.strokes.json");

/// One picture of the turn.
pub(crate) type Frame = Arc<image::RgbaImage>;

/// The worker that opens the scan to be turned.
pub(crate) type Loader = Box<dyn Worker<VolumeSource, Result<Box<LoadedVolume>, OpenError>>>;

/// Where the attract mode's loader and controller come from: threads and the GPU on the
/// panel, inline work and a renderer without a GPU in tests.
pub(crate) struct Workers {
    pub loader: fn(OpenOptions) -> Loader,
    pub controller: fn() -> Controller,
}

impl Default for Workers {
    /// A loader thread, and a controller with its own render thread and classification jobs.
    fn default() -> Self {
        Workers {
            loader: |options| Box::new(Threaded::new("attract", open_task(options))),
            controller: || Controller::new(None),
        }
    }
}

/// The task that opens a scan, guarded against a reader that panics.
pub(crate) fn open_task(options: OpenOptions) -> Task<VolumeSource, Result<Box<LoadedVolume>, OpenError>> {
    Arc::new(move |source, _: &Ticket, report: &Report<'_, Result<Box<LoadedVolume>, OpenError>>| {
        // A turntable is public: it never reads who the patient is.
        report(library::guarded(&source, || library::load(&source, &options, PatientShown::Hidden)).map(Box::new))
    })
}

/// What the turntable shows.
#[derive(Clone, Debug)]
pub(crate) struct Showing {
    session: SavedSession,
    name: String,
    camera: Camera,
    visible: Vec<bool>,
}

enum Phase {
    Off,
    Loading {
        showing: Showing,
        loader: Loader,
        side: u32,
    },
    Rendering {
        showing: Showing,
        ctl: Box<Controller>,
        frames: Vec<Frame>,
        side: u32,
        awaited: Option<u64>,
    },
    Playing {
        frames: Vec<Frame>,
        /// The picture shown next, and when.
        next: usize,
        next_at: Duration,
        name: String,
        /// What was turned, at which size ([`turn_key`]).
        key: String,
    },
}

/// One prepared turn, kept while the app is not on the start screen.
struct Turn {
    key: String,
    frames: Vec<Frame>,
    name: String,
}

/// A picture for the start screen, under its caption.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Shown {
    pub frame: Frame,
    pub caption: String,
}

/// The attract mode's part of the app's state.
pub(crate) struct Attract {
    phase: Phase,
    /// The last turn prepared, played again when the same result is shown at the same size.
    last_turn: Option<Turn>,
    workers: Workers,
}

impl Default for Attract {
    fn default() -> Self {
        Attract::with_workers(Workers::default())
    }
}

impl Attract {
    pub(crate) fn with_workers(workers: Workers) -> Attract {
        Attract { phase: Phase::Off, last_turn: None, workers }
    }

    /// The turn is being prepared (replay's `wait-idle` waits for it).
    pub(crate) fn busy(&self) -> bool {
        matches!(self.phase, Phase::Loading { .. } | Phase::Rendering { .. })
    }

    /// `off`, `loading`, `rendering` or `playing` (replay's `expect attract`).
    pub(crate) fn describe(&self) -> &'static str {
        match self.phase {
            Phase::Off => "off",
            Phase::Loading { .. } => "loading",
            Phase::Rendering { .. } => "rendering",
            Phase::Playing { .. } => "playing",
        }
    }

    /// The idle timeout brought the start screen back at `now`: the turntable of `showing`
    /// starts, at pictures of `side` pixels: at once from the turn kept when it is the same,
    /// else opened, classified and rendered first.
    pub(crate) fn begin(&mut self, showing: Showing, side: u32, options: OpenOptions, now: Duration) {
        if !matches!(self.phase, Phase::Off) {
            return;
        }
        let key = turn_key(&showing, side);
        if let Some(turn) = self.last_turn.take_if(|turn| turn.key == key) {
            log::info!("attract mode: the turntable of {} again, as prepared before", turn.name);
            self.phase = Phase::Playing { frames: turn.frames, next: 0, next_at: now, name: turn.name, key: turn.key };
            return;
        }
        let mut loader = (self.workers.loader)(options);
        loader.send(VolumeSource::from_key(&showing.session.volume));
        log::info!("attract mode: a turntable of {}", showing.name);
        self.phase = Phase::Loading { showing, loader, side };
    }

    /// The start screen is left: the turntable stops; a whole turn is kept for next time.
    pub(crate) fn end(&mut self) {
        match std::mem::replace(&mut self.phase, Phase::Off) {
            Phase::Rendering { mut ctl, .. } => ctl.jobs.cancel(),
            Phase::Playing { frames, name, key, .. } => self.last_turn = Some(Turn { key, frames, name }),
            Phase::Off | Phase::Loading { .. } => {}
        }
    }

    /// The poll's tick at `now`: preparation moves on; while playing, the picture that is due.
    pub(crate) fn tick(&mut self, now: Duration) -> Option<Shown> {
        let (next, shown) = match std::mem::replace(&mut self.phase, Phase::Off) {
            Phase::Off => (Phase::Off, None),
            Phase::Loading { showing, mut loader, side } => match loader.poll().map(|delivery| delivery.output) {
                None if loader.ended_silently().is_some() => (stopped("the loader stopped"), None),
                None => (Phase::Loading { showing, loader, side }, None),
                Some(Err(error)) => (stopped(&format!("cannot open {}: {error}", showing.name)), None),
                Some(Ok(loaded)) => {
                    let mut ctl = Box::new((self.workers.controller)());
                    ctl.open(Work::new(*loaded), Some(showing.session.clone()));
                    for (index, shown) in showing.visible.iter().enumerate() {
                        if !shown {
                            ctl.toggle_class(index);
                        }
                    }
                    (Phase::Rendering { showing, ctl, frames: Vec::new(), side, awaited: None }, None)
                }
            },
            Phase::Rendering { showing, ctl, frames, side, awaited } => {
                (render(showing, ctl, frames, side, awaited, now), None)
            }
            Phase::Playing { frames, next, next_at, name, key } if now >= next_at && !frames.is_empty() => {
                let shown = Shown { frame: frames[next % frames.len()].clone(), caption: name.clone() };
                let interval = Duration::from_millis(1000 / FRAMES_PER_SECOND);
                // A late tick does not make the turn hurry to catch up.
                let next_at = (next_at + interval).max(now);
                (Phase::Playing { next: (next + 1) % frames.len(), frames, next_at, name, key }, Some(shown))
            }
            playing @ Phase::Playing { .. } => (playing, None),
        };
        self.phase = next;
        shown
    }
}

/// The newest kept result in `data_dir` whose scan is there, else the demo with its benchmark
/// lassos.
pub(crate) fn what_to_show(data_dir: Option<&Path>) -> Option<Showing> {
    let listed = data_dir.map(gallery::list).unwrap_or_default();
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

/// What a turn shows and at which size: equal keys, equal pictures. The scan's file or folder
/// is named with its length and modification time, so a scan replaced at the same path (a
/// series received again) is rendered anew, never shown from the old pictures.
fn turn_key(showing: &Showing, side: u32) -> String {
    let source = VolumeSource::from_key(&showing.session.volume);
    let stamp =
        source.path().and_then(|path| std::fs::metadata(path).ok()).map(|meta| (meta.len(), meta.modified().ok()));
    format!("{side} {stamp:?} {showing:?}")
}

fn stopped(reason: &str) -> Phase {
    log::warn!("attract mode: {reason}; the start screen stays still");
    Phase::Off
}

/// Classification, then one turn's pictures one after another; the controller goes once the
/// turn is whole, and the turn plays from `now`.
fn render(
    showing: Showing,
    mut ctl: Box<Controller>,
    mut frames: Vec<Frame>,
    side: u32,
    mut awaited: Option<u64>,
    now: Duration,
) -> Phase {
    let changed = ctl.poll();
    let classified = ctl.work.as_ref().is_some_and(|work| work.classified.is_some());
    if let Some(status) = changed.status.filter(|_| !classified) {
        return stopped(&format!("the classification failed: {status}"));
    }
    if !classified {
        return Phase::Rendering { showing, ctl, frames, side, awaited };
    }
    while let Some(reply) = ctl.renderer.poll() {
        match reply {
            RenderReply::Failed(error) => return stopped(&error.to_string()),
            RenderReply::Picture(picture) if Some(picture.id) == awaited && picture.whole => {
                frames.push(Arc::new(picture.image));
                awaited = None;
            }
            RenderReply::Picture(_) => {}
        }
    }
    if frames.len() == FRAMES {
        ctl.jobs.cancel();
        drop(ctl);
        log::info!("attract mode: {} pictures of {} ready", frames.len(), showing.name);
        let key = turn_key(&showing, side);
        return Phase::Playing { frames, next: 0, next_at: now, name: showing.name, key };
    }
    if awaited.is_none() {
        let mut camera = showing.camera;
        camera.azimuth_degrees += 360.0 * frames.len() as f32 / FRAMES as f32;
        awaited = Some(ctl.renderer.request_whole_frame(camera, [side, side]));
    }
    Phase::Rendering { showing, ctl, frames, side, awaited }
}

#[cfg(test)]
mod tests;
