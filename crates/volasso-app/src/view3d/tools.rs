//! The 3-D view's tools as the app applies them: a class's opacity slider, the view's touches
//! and buttons (camera and clip plane, decided by interaction.rs), the snapshot (snapshot.rs),
//! and the renderer's pictures collected and new frames asked for.
//!
//! Never: draws, reads input devices or touches the disk itself.

use crate::model::{AppModel, Show};
use crate::view3d::RenderReply;
use crate::view3d::clip;
use crate::view3d::interaction::{Scene, ViewIntent};
use crate::view3d::snapshot::Places;
use volasso_core::render::ClipPlane;

impl AppModel {
    /// The opacity slider of class row `index` moved to `percent`: the 3-D view redraws, the
    /// row's knob follows, and the slices are redrawn only when the class appears or
    /// disappears there.
    pub(crate) fn class_opacity(&mut self, index: usize, percent: i32) -> Show {
        let changed = self.ctl.set_class_opacity(index, percent);
        if changed.view {
            self.view.dirty = true;
        }
        // The row is updated in place: replacing the rows would end the finger's drag.
        let show = Show { class_opacity: Some(index), ..Show::default() };
        if changed.classes { show.and(Show::every_panel()) } else { show }
    }

    /// The volume's box in mm, when one is open.
    fn open_extent(&self) -> Option<[f32; 3]> {
        let volume = &self.ctl.work.as_ref()?.loaded.volume;
        Some(clip::extent_mm(volume.dims, volume.spacing_mm))
    }

    /// A new clip plane (or none): to the renderer, the slices and (when `save`) the session.
    fn set_clip(&mut self, plane: Option<ClipPlane>, save: bool) -> Show {
        self.ctl.look.clip = plane;
        self.ctl.renderer.set_clip(plane);
        self.view.dirty = true;
        if save {
            self.ctl.save();
        }
        Show { clipping: true, ..Show::every_panel() }
    }

    /// A touch or button on the 3-D view (`interaction::ViewIntent`): the model moves the
    /// camera or the clip plane; a new plane goes to the renderer, the slices and, once final,
    /// the session.
    pub(crate) fn view_intent(&mut self, intent: ViewIntent) -> Show {
        let scene = Scene { extent_mm: self.open_extent(), clip: self.ctl.look.clip };
        let effects = self.view.update(intent, scene);
        let show = match effects.clip {
            Some(change) => self.set_clip(change.plane, change.save),
            None => Show::default(),
        };
        if effects.save {
            self.ctl.save();
        }
        show
    }

    /// "Snapshot": the 3-D view's newest picture to the data folder and any USB stick.
    pub(crate) fn snapshot(&mut self) -> Show {
        let places = Places { data_dir: self.config.data_dir.clone(), media_roots: self.config.media_roots.clone() };
        match self.view_picture.clone().filter(|_| self.ctl.work.is_some()) {
            Some(picture) => {
                self.snapshots.start(picture, places);
                Show::default()
            }
            None => Show {
                toast: Some("Nothing to save yet: the 3-D view shows no picture".to_string()),
                ..Show::default()
            },
        }
    }

    /// Collects finished snapshots: their confirmation is shown over the view.
    pub(crate) fn poll_snapshots(&mut self) -> Show {
        let Some(outcome) = self.snapshots.poll() else { return Show::default() };
        let message = outcome.message();
        log::info!("{message}");
        Show { toast: Some(message), ..Show::default() }
    }

    /// Collects the renderer's newest picture, or says why it failed in the banner.
    pub(crate) fn poll_renderer(&mut self) -> Show {
        match self.ctl.renderer.poll() {
            Some(RenderReply::Picture(picture)) => {
                self.view_picture = Some(picture.image);
                Show { view_picture: true, ..Show::default() }
            }
            Some(RenderReply::Failed(error)) => {
                let message = error.to_string();
                log::warn!("{message}");
                self.banner = message;
                Show::status()
            }
            None => Show::default(),
        }
    }

    /// Asks the renderer for a frame of `size` pixels when the view needs one and none is
    /// being drawn: half size while a finger orbits (twice the frame rate on a slow GPU), full
    /// size when it lifts.
    pub(crate) fn request_frame_if_needed(&mut self, size: [u32; 2]) {
        self.view.update(ViewIntent::Resized(size), Scene::default());
        let classified = self.ctl.work.as_ref().is_some_and(|work| work.classified.is_some());
        if !self.view.dirty || self.ctl.renderer.busy() || !classified || size[0] == 0 || size[1] == 0 {
            if !classified {
                self.view.dirty = false;
            }
            return;
        }
        self.view.dirty = false;
        let size = if self.view.orbiting() { size.map(|side| (side / 2).max(1)) } else { size };
        let camera = self.view.camera;
        self.ctl.renderer.request_frame(camera, size);
    }
}
