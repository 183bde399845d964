//! The 3-D view as touch moves it: one finger orbits the camera (or, while clipping, moves the
//! clip plane along its normal), two fingers zoom, pan and turn (or, while clipping, tilt the
//! plane), "Reset view" goes home, "Clip" and "Reset clip" put the plane through the centre
//! facing the viewer (the plane's geometry is clip.rs). A model updated by [`ViewIntent`]s,
//! tested without a window, a GPU or a thread.
//!
//! Never: draws, holds the clip plane (the work's look does, [`Scene::clip`]), or saves; it
//! says in [`ViewEffects`] what the caller must pass on.

use crate::view3d::clip;
use volasso_core::render::{Camera, ClipPlane};

/// Degrees the camera turns per pixel a finger moves while orbiting.
pub const ORBIT_DEGREES_PER_PIXEL: f32 = 0.4;

/// The 3-D view's zoom, least and most.
pub const ZOOM_RANGE: (f32, f32) = (0.25, 8.0);

/// What a single finger on the view is doing.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Finger {
    /// Turning the camera; its last position.
    Orbiting([f32; 2]),
    /// Moving the clip plane; its last position.
    Clipping([f32; 2]),
}

/// The view's camera and what a finger on it is doing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ViewModel {
    /// The camera the next frame is drawn from.
    pub camera: Camera,
    /// Where "Reset view" takes the camera: the open volume's anterior view, head up, when its
    /// orientation is known (`slices::HomeView`).
    pub home: Camera,
    finger: Option<Finger>,
    /// The size the view is drawn at, in pixels.
    pub size: [u32; 2],
    /// A new frame is wanted (camera, clip, classes or size changed).
    pub dirty: bool,
}

/// What the model reads of the open work.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Scene {
    /// The volume's box in mm; `None` with no volume open.
    pub extent_mm: Option<[f32; 3]>,
    /// The clip plane in use; `None`: nothing cut.
    pub clip: Option<ClipPlane>,
}

/// A touch or a button on the 3-D view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ViewIntent {
    /// A finger down at a point (logical pixels).
    Press([f32; 2]),
    /// The finger moved to a point, on a view `view_height` logical pixels high.
    Drag { to: [f32; 2], view_height: u32 },
    /// The finger lifted.
    Release,
    /// Two fingers: `zoom` multiplies the zoom, `pan_pixels` moves the picture, `turn_degrees`
    /// turns it about the view direction.
    Gesture { zoom: f32, pan_pixels: [f32; 2], turn_degrees: f32 },
    /// "Reset view".
    ResetView,
    /// "Clip": on through the centre facing the viewer, or off.
    ToggleClip,
    /// "Reset clip": the plane back where "Clip" put it, for the current view.
    ResetClip,
    /// The view is drawn at a new size (pixels).
    Resized([u32; 2]),
}

/// A new clip plane for the work's look, the renderer and the slices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipChange {
    /// The plane; `None`: nothing cut.
    pub plane: Option<ClipPlane>,
    /// The session is saved with it (not while a finger is still moving it).
    pub save: bool,
}

/// What an update asks of the caller.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewEffects {
    pub clip: Option<ClipChange>,
    /// The clip plane's place is final after a drag: save the session.
    pub save: bool,
}

impl ViewModel {
    /// A volume opened: the camera goes to its home.
    pub fn open(&mut self, home: Camera) {
        self.home = home;
        self.camera = home;
        self.finger = None;
        self.dirty = true;
    }

    /// Back to the start screen: no volume, the default camera.
    pub fn forget(&mut self) {
        *self = ViewModel { size: self.size, ..ViewModel::default() };
    }

    /// A finger is turning the camera (frames are drawn at half size meanwhile).
    pub fn orbiting(&self) -> bool {
        matches!(self.finger, Some(Finger::Orbiting(_)))
    }

    /// Applies `intent` to the view showing `scene`.
    pub fn update(&mut self, intent: ViewIntent, scene: Scene) -> ViewEffects {
        let mut effects = ViewEffects::default();
        match intent {
            ViewIntent::Press(at) => {
                self.finger = Some(if scene.clip.is_some() { Finger::Clipping(at) } else { Finger::Orbiting(at) });
            }
            ViewIntent::Drag { to, view_height } => match self.finger {
                Some(Finger::Orbiting(from)) => {
                    let camera = &mut self.camera;
                    camera.azimuth_degrees -= (to[0] - from[0]) * ORBIT_DEGREES_PER_PIXEL;
                    camera.elevation_degrees =
                        (camera.elevation_degrees + (to[1] - from[1]) * ORBIT_DEGREES_PER_PIXEL).clamp(-89.0, 89.0);
                    self.finger = Some(Finger::Orbiting(to));
                    self.dirty = true;
                }
                Some(Finger::Clipping(from)) => {
                    self.finger = Some(Finger::Clipping(to));
                    if let (Some(plane), Some(extent)) = (scene.clip, scene.extent_mm) {
                        let plane = clip::moved(plane, to[1] - from[1], view_height.max(1), extent);
                        effects.clip = Some(ClipChange { plane: Some(plane), save: false });
                        self.dirty = true;
                    }
                }
                None => {}
            },
            ViewIntent::Release => {
                effects.save = matches!(self.finger, Some(Finger::Clipping(_)));
                self.finger = None;
                self.dirty = true;
            }
            ViewIntent::Gesture { zoom, pan_pixels, turn_degrees } => {
                self.gesture(zoom, pan_pixels, turn_degrees, scene, &mut effects);
            }
            ViewIntent::ResetView => {
                self.camera = self.home;
                self.dirty = true;
            }
            ViewIntent::ToggleClip => {
                let plane = match (scene.clip, scene.extent_mm) {
                    (Some(_), _) | (None, None) => None,
                    (None, Some(extent)) => Some(clip::initial(&self.camera, extent)),
                };
                effects.clip = Some(ClipChange { plane, save: true });
                self.dirty = true;
            }
            ViewIntent::ResetClip => {
                if let Some(extent) = scene.clip.and(scene.extent_mm) {
                    let plane = Some(clip::initial(&self.camera, extent));
                    effects.clip = Some(ClipChange { plane, save: true });
                    self.dirty = true;
                }
            }
            ViewIntent::Resized(size) => {
                if size != self.size {
                    self.size = size;
                    self.dirty = true;
                }
            }
        }
        effects
    }

    /// Two fingers: the zoom always; while clipping the pan and the turn tilt the plane,
    /// otherwise they move and turn the camera.
    fn gesture(&mut self, zoom: f32, pan_pixels: [f32; 2], turn_degrees: f32, scene: Scene, effects: &mut ViewEffects) {
        if zoom.is_finite() && zoom > 0.0 {
            self.camera.zoom = (self.camera.zoom * zoom).clamp(ZOOM_RANGE.0, ZOOM_RANGE.1);
        }
        let moved = pan_pixels != [0.0; 2] || turn_degrees != 0.0;
        if let (true, Some(plane), Some(extent)) = (moved, scene.clip, scene.extent_mm) {
            let plane = clip::tilted(plane, &self.camera, extent, pan_pixels, turn_degrees);
            effects.clip = Some(ClipChange { plane: Some(plane), save: true });
        } else {
            let [width, height] = self.size;
            if let Some(extent) = scene.extent_mm
                && pan_pixels.iter().all(|p| p.is_finite())
                && width > 0
            {
                self.camera.pan_by_pixels(pan_pixels[0], pan_pixels[1], extent, width, height);
            }
            if turn_degrees.is_finite() {
                self.camera.azimuth_degrees -= turn_degrees;
            }
        }
        self.dirty = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXTENT: [f32; 3] = [200.0, 200.0, 150.0];

    fn open() -> Scene {
        Scene { extent_mm: Some(EXTENT), clip: None }
    }

    /// The model after a volume opened at a view of 800 x 600 pixels, nothing to draw yet.
    fn view() -> ViewModel {
        let mut view = ViewModel::default();
        view.update(ViewIntent::Resized([800, 600]), open());
        view.open(Camera::default());
        view.dirty = false;
        view
    }

    #[test]
    fn one_finger_orbits_the_camera_and_lifting_it_draws_a_whole_frame() {
        let mut view = view();
        view.update(ViewIntent::Press([100.0, 100.0]), open());
        assert!(view.orbiting());
        let effects = view.update(ViewIntent::Drag { to: [150.0, 80.0], view_height: 600 }, open());
        assert_eq!(effects, ViewEffects::default());
        assert_eq!(view.camera.azimuth_degrees, Camera::default().azimuth_degrees - 50.0 * ORBIT_DEGREES_PER_PIXEL);
        assert_eq!(view.camera.elevation_degrees, Camera::default().elevation_degrees - 20.0 * ORBIT_DEGREES_PER_PIXEL);
        assert!(view.dirty);
        view.dirty = false;
        assert_eq!(view.update(ViewIntent::Release, open()), ViewEffects::default());
        assert!(!view.orbiting() && view.dirty, "a whole frame after the half-size ones");
    }

    #[test]
    fn the_elevation_stops_short_of_the_poles() {
        let mut view = view();
        view.update(ViewIntent::Press([0.0, 0.0]), open());
        view.update(ViewIntent::Drag { to: [0.0, 10_000.0], view_height: 600 }, open());
        assert_eq!(view.camera.elevation_degrees, 89.0);
        view.update(ViewIntent::Drag { to: [0.0, -10_000.0], view_height: 600 }, open());
        assert_eq!(view.camera.elevation_degrees, -89.0);
    }

    #[test]
    fn clip_puts_a_plane_through_the_centre_and_again_takes_it_away() {
        let mut view = view();
        let on = view.update(ViewIntent::ToggleClip, open());
        let plane = clip::initial(&view.camera, EXTENT);
        assert_eq!(on.clip, Some(ClipChange { plane: Some(plane), save: true }));
        let clipped = Scene { clip: Some(plane), ..open() };
        let off = view.update(ViewIntent::ToggleClip, clipped);
        assert_eq!(off.clip, Some(ClipChange { plane: None, save: true }));
        // Without a volume there is nothing to cut.
        let none = view.update(ViewIntent::ToggleClip, Scene::default());
        assert_eq!(none.clip, Some(ClipChange { plane: None, save: true }));
    }

    #[test]
    fn while_clipping_a_finger_moves_the_plane_not_the_camera_and_lifting_it_saves() {
        let mut view = view();
        let plane = clip::initial(&view.camera, EXTENT);
        let clipped = Scene { clip: Some(plane), ..open() };
        let camera = view.camera;
        view.update(ViewIntent::Press([100.0, 100.0]), clipped);
        assert!(!view.orbiting());
        let moved = view.update(ViewIntent::Drag { to: [100.0, 160.0], view_height: 600 }, clipped);
        let expected = clip::moved(plane, 60.0, 600, EXTENT);
        assert_eq!(moved.clip, Some(ClipChange { plane: Some(expected), save: false }));
        assert_ne!(expected, plane);
        assert_eq!(view.camera, camera);
        let lifted = view.update(ViewIntent::Release, Scene { clip: Some(expected), ..open() });
        assert!(lifted.save && lifted.clip.is_none());
        // A second lift saves nothing more.
        assert!(!view.update(ViewIntent::Release, clipped).save);
    }

    #[test]
    fn two_fingers_tilt_the_plane_while_clipping_and_move_the_camera_otherwise() {
        let mut view = view();
        let plane = clip::initial(&view.camera, EXTENT);
        let clipped = Scene { clip: Some(plane), ..open() };
        let camera = view.camera;
        let gesture = ViewIntent::Gesture { zoom: 2.0, pan_pixels: [30.0, 0.0], turn_degrees: 10.0 };
        let tilted = view.update(gesture, clipped);
        let expected = clip::tilted(plane, &view.camera, EXTENT, [30.0, 0.0], 10.0);
        assert_eq!(tilted.clip, Some(ClipChange { plane: Some(expected), save: true }));
        assert_eq!(view.camera.zoom, camera.zoom * 2.0, "the zoom goes to the camera either way");
        assert_eq!((view.camera.azimuth_degrees, view.camera.pan_mm), (camera.azimuth_degrees, camera.pan_mm));
        let mut free = self::view();
        let untouched = free.update(gesture, open());
        assert_eq!(untouched.clip, None);
        assert_eq!(free.camera.azimuth_degrees, camera.azimuth_degrees - 10.0);
        assert_ne!(free.camera.pan_mm, camera.pan_mm);
    }

    #[test]
    fn the_zoom_stays_in_its_range_and_ignores_a_nonsense_factor() {
        let mut view = view();
        for factor in [f32::NAN, f32::INFINITY, -2.0, 0.0] {
            view.update(ViewIntent::Gesture { zoom: factor, pan_pixels: [0.0; 2], turn_degrees: 0.0 }, open());
            assert_eq!(view.camera.zoom, Camera::default().zoom, "{factor}");
        }
        view.update(ViewIntent::Gesture { zoom: 1e9, pan_pixels: [0.0; 2], turn_degrees: 0.0 }, open());
        assert_eq!(view.camera.zoom, ZOOM_RANGE.1);
        view.update(ViewIntent::Gesture { zoom: 1e-9, pan_pixels: [0.0; 2], turn_degrees: 0.0 }, open());
        assert_eq!(view.camera.zoom, ZOOM_RANGE.0);
    }

    #[test]
    fn reset_view_goes_home_and_forgetting_keeps_only_the_size() {
        let mut view = ViewModel::default();
        let home = Camera { azimuth_degrees: 180.0, ..Camera::default() };
        view.update(ViewIntent::Resized([640, 480]), open());
        view.open(home);
        assert_eq!(view.camera, home);
        view.update(ViewIntent::Press([0.0, 0.0]), open());
        view.update(ViewIntent::Drag { to: [90.0, 0.0], view_height: 480 }, open());
        assert_ne!(view.camera, home);
        view.update(ViewIntent::ResetView, open());
        assert_eq!(view.camera, home);
        view.forget();
        assert_eq!(view, ViewModel { size: [640, 480], ..ViewModel::default() });
    }

    #[test]
    fn reset_clip_does_nothing_while_not_clipping() {
        let mut view = view();
        assert_eq!(view.update(ViewIntent::ResetClip, open()), ViewEffects::default());
        assert!(!view.dirty);
        let plane = clip::moved(clip::initial(&view.camera, EXTENT), 40.0, 600, EXTENT);
        let reset = view.update(ViewIntent::ResetClip, Scene { clip: Some(plane), ..open() });
        let initial = clip::initial(&view.camera, EXTENT);
        assert_eq!(reset.clip, Some(ClipChange { plane: Some(initial), save: true }));
    }
}
