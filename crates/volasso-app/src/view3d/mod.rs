//! The 3-D view's renderer: a [`Serial`] worker whose one thread owns the GPU device and the
//! ray caster, draws the classified volume offscreen and hands back pictures. The UI thread
//! only sends requests and shows the newest picture, so a slow GPU (lavapipe takes seconds per
//! frame) never blocks it. A frame request waiting behind a newer one is skipped.
//! Frames are progressive ([`volasso_core::render::progressive`]): each request is answered at once
//! with a preview sized to 150 ms, then, while no newer request is sent, the full frame is
//! drawn band by band and sent with the same id; any newer request abandons it, and it is drawn
//! again once that is applied. A caller that keeps only whole frames (attract mode's
//! turntable) asks for them without a preview.
//!
//! Why offscreen and read back: Slint's software renderer (the appliance on DRM, the replay
//! harness) can only show pixels, and a GPU panel pays about 4 MB of copy per frame for it.
//!
//! A class's opacity factor and the clip plane change the class table or the frame's settings
//! alone: the labels are not sent again.
//!
//! Before a volume is uploaded its memory map is checked (`Volume::check_still_mapped`): a file
//! truncated while open gives a message, not a crash.
//!
//! Never: touches Slint; never renders on the UI thread.

pub mod clip;
pub mod interaction;
pub mod snapshot;
pub(crate) mod tools;

use crate::worker::{Inline, Report, Serial, Task, Ticket, Worker};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use volasso_core::render::headless::OFFSCREEN_FORMAT;
use volasso_core::render::progressive::ProgressiveView;
use volasso_core::render::{Camera, ClipPlane, RayCaster, RenderMode, RenderSettings, gpu};
use volasso_core::transfer::ClassStyle;
use volasso_core::volume::Volume;

/// The largest side of a picture: beyond it, pictures are drawn smaller and scaled up.
pub const MAX_PICTURE_SIDE: u32 = 1600;

/// What the renderer is asked to do, in order.
enum Request {
    Volume(Arc<Volume>),
    Labels(Arc<Vec<u8>>, Vec<ClassStyle>),
    Styles(Vec<ClassStyle>),
    /// Class `label`'s opacity factor (`RayCaster::set_class_opacity`).
    ClassOpacity(u8, f32),
    Clip(Option<ClipPlane>),
    Frame(FrameRequest),
}

/// A frame asked for: its id, camera and size, and whether a preview comes first.
#[derive(Clone, Copy, Debug)]
struct FrameRequest {
    id: u64,
    camera: Camera,
    size: [u32; 2],
    preview: bool,
}

/// A drawn picture.
#[derive(Debug)]
pub struct Picture {
    pub id: u64,
    pub image: image::RgbaImage,
    pub seconds: f64,
    /// The full frame (false: its preview).
    pub whole: bool,
}

/// What comes back from the renderer.
#[derive(Debug)]
pub enum RenderReply {
    Picture(Picture),
    /// The GPU could not be opened or a frame failed; the rest of the UI goes on.
    Failed(ViewError),
}

/// Why the 3-D view shows nothing new; the rest of the UI goes on.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error("3-D view unavailable: {0}")]
    Unavailable(#[source] volasso_core::render::RenderError),
    #[error("3-D view: {0}")]
    Render(#[source] volasso_core::render::RenderError),
    /// The volume's file shrank under its memory map since it was opened.
    #[error("3-D view: {0}")]
    VolumeGone(#[source] volasso_core::volume::VolumeError),
}

/// The UI thread's handle on the render thread.
pub struct ViewRenderer {
    worker: Box<dyn Worker<Request, RenderReply>>,
    next_id: u64,
    /// The newest frame asked for and not yet received.
    awaited: Option<u64>,
    /// How many classifications were sent (a restyle or a first look counts none).
    label_uploads: usize,
    /// The newest frame asked for has come back whole (or failed): nothing more will come.
    settled: bool,
}

impl Default for ViewRenderer {
    fn default() -> Self {
        Self::new()
    }
}

impl ViewRenderer {
    /// Starts the render thread; the GPU is opened there, on the first request.
    pub fn new() -> ViewRenderer {
        let frame_after_frame =
            |older: &Request, newer: &Request| matches!((older, newer), (Request::Frame(_), Request::Frame(_)));
        ViewRenderer::over(Box::new(Serial::new("render", render_task(), Arc::new(frame_after_frame))))
    }

    /// A renderer with no thread and no GPU: requests are taken and counted, no picture ever
    /// comes back. For the logic's tests, which check what is sent, not what is drawn.
    pub fn without_gpu() -> ViewRenderer {
        ViewRenderer::over(Box::new(Inline::new(Arc::new(|_: Request, _: &Ticket, _: &Report<'_, RenderReply>| {}))))
    }

    /// A renderer with no thread and no GPU that answers every frame, at the next poll, with a
    /// blank picture of the size asked, filled with a grey from the camera's azimuth (so frames
    /// from different sides differ). For the tests of logic that waits for pictures.
    pub fn blank_pictures() -> ViewRenderer {
        let task: Task<Request, RenderReply> =
            Arc::new(|request: Request, _: &Ticket, report: &Report<'_, RenderReply>| {
                if let Request::Frame(FrameRequest { id, camera, size, .. }) = request {
                    let grey = (camera.azimuth_degrees.rem_euclid(360.0) / 2.0) as u8;
                    let image = image::RgbaImage::from_pixel(size[0], size[1], image::Rgba([grey, grey, grey, 255]));
                    report(RenderReply::Picture(Picture { id, image, seconds: 0.0, whole: true }));
                }
            });
        ViewRenderer::over(Box::new(Inline::new(task)))
    }

    /// A renderer that has asked for nothing yet, over `worker`.
    fn over(worker: Box<dyn Worker<Request, RenderReply>>) -> ViewRenderer {
        ViewRenderer { worker, next_id: 0, awaited: None, label_uploads: 0, settled: true }
    }

    /// Ends the render thread and waits for it (at most the band it is drawing). Later
    /// requests are ignored.
    pub fn shut_down(&mut self) {
        self.worker.cancel();
        // Dropping the render thread's worker waits for the thread.
        self.worker = Box::new(Inline::new(Arc::new(|_: Request, _: &Ticket, _: &Report<'_, RenderReply>| {})));
    }

    pub fn set_volume(&mut self, volume: Arc<Volume>) {
        self.worker.send(Request::Volume(volume));
    }

    /// A new classification: its label volume (uploaded and its bricks rebuilt) and styles.
    pub fn set_labels(&mut self, labels: Arc<Vec<u8>>, styles: Vec<ClassStyle>) {
        self.label_uploads += 1;
        self.worker.send(Request::Labels(labels, styles));
    }

    /// A first, coarse classification: sent as [`ViewRenderer::set_labels`] sends one, not
    /// counted in [`ViewRenderer::label_uploads`] (whether it comes before the exact one
    /// depends on timing).
    pub fn set_first_look(&mut self, labels: Arc<Vec<u8>>, styles: Vec<ClassStyle>) {
        self.worker.send(Request::Labels(labels, styles));
    }

    /// How many classifications were sent so far (first looks not counted).
    pub fn label_uploads(&self) -> usize {
        self.label_uploads
    }

    /// New colours or visibility for the labels already sent: the class table alone.
    pub fn set_styles(&mut self, styles: Vec<ClassStyle>) {
        self.worker.send(Request::Styles(styles));
    }

    /// Class `label` (1-based) drawn with opacity `factor` (1: the default rule's); the class
    /// table alone changes.
    pub fn set_class_opacity(&mut self, label: u8, factor: f32) {
        self.worker.send(Request::ClassOpacity(label, factor));
    }

    /// The clip plane of the next frames; `None`: nothing cut.
    pub fn set_clip(&mut self, clip: Option<ClipPlane>) {
        self.worker.send(Request::Clip(clip));
    }

    /// Asks for a frame of `size` pixels: its preview comes first, then the whole frame, with
    /// the same id; returns the id.
    pub fn request_frame(&mut self, camera: Camera, size: [u32; 2]) -> u64 {
        self.send_frame_request(camera, size, true)
    }

    /// Asks for the whole frame only (no preview before it); returns its id. For pictures
    /// that are kept rather than watched: on a slow GPU the preview costs a third as much
    /// again.
    pub fn request_whole_frame(&mut self, camera: Camera, size: [u32; 2]) -> u64 {
        self.send_frame_request(camera, size, false)
    }

    fn send_frame_request(&mut self, camera: Camera, size: [u32; 2], preview: bool) -> u64 {
        self.next_id += 1;
        let scale = (MAX_PICTURE_SIDE as f32 / size[0].max(size[1]).max(1) as f32).min(1.0);
        let size = size.map(|side| ((side as f32 * scale) as u32).max(1));
        self.worker.send(Request::Frame(FrameRequest { id: self.next_id, camera, size, preview }));
        self.awaited = Some(self.next_id);
        self.settled = false;
        self.next_id
    }

    /// True when the newest frame asked for is shown whole (or failed), so the view will not
    /// change until asked again (replay's `wait-idle`).
    pub fn settled(&self) -> bool {
        self.settled
    }

    /// True while a requested frame has not come back.
    pub fn busy(&self) -> bool {
        self.awaited.is_some()
    }

    /// The next reply, if one is ready; never blocks.
    pub fn poll(&mut self) -> Option<RenderReply> {
        // A request that drew nothing (a new class table, a frame a newer request abandoned)
        // ends without a word; that is no failure.
        while self.worker.ended_silently().is_some() {}
        let reply = self.worker.poll()?.output;
        match &reply {
            RenderReply::Picture(picture) if Some(picture.id) == self.awaited => self.awaited = None,
            RenderReply::Failed(_) => {
                self.awaited = None;
                self.settled = true;
            }
            RenderReply::Picture(_) => {}
        }
        if let RenderReply::Picture(picture) = &reply
            && picture.id == self.next_id
            && picture.whole
        {
            self.settled = true;
        }
        Some(reply)
    }
}

impl Drop for ViewRenderer {
    fn drop(&mut self) {
        self.shut_down();
    }
}

/// The GPU side: opened lazily, kept for the thread's life.
struct GpuScene {
    ray_caster: RayCaster,
    view: ProgressiveView,
    /// The frame being refined, and when it was asked for.
    refining: Option<(FrameRequest, Instant)>,
    has_volume: bool,
    has_labels: bool,
    clip: Option<ClipPlane>,
}

/// What the render thread keeps between requests: the GPU scene, opened on the first request,
/// and whether opening it failed (then every request is ignored).
struct RenderState {
    scene: Option<GpuScene>,
    failed: bool,
}

/// The render thread's task: each request is applied to the scene; a frame asked for, or the
/// frame being refined when the request came, is drawn (its preview, then band by band) while
/// no newer request is sent.
fn render_task() -> Task<Request, RenderReply> {
    let state = Mutex::new(RenderState { scene: None, failed: false });
    Arc::new(move |request: Request, ticket: &Ticket, report: &Report<'_, RenderReply>| {
        // A job that panicked leaves the lock poisoned: the 3-D view stays as it is.
        let Ok(mut state) = state.lock() else { return };
        apply(&mut state, request, ticket, report);
    })
}

fn apply(state: &mut RenderState, request: Request, ticket: &Ticket, report: &Report<'_, RenderReply>) {
    if state.failed {
        return;
    }
    if state.scene.is_none() {
        match open_scene() {
            Ok(opened) => state.scene = Some(opened),
            Err(error) => {
                state.failed = true;
                report(RenderReply::Failed(error));
                return;
            }
        }
    }
    let Some(scene) = state.scene.as_mut() else { return };
    // The scene or the camera changes: the full frame being refined is out of date; without a
    // new camera it is started again.
    let mut frame = scene.refining.take().map(|(frame, _)| frame);
    scene.view.cancel_full();
    let result = match request {
        Request::Volume(volume) => {
            scene.has_labels = false;
            // A volume file truncated since it was opened would crash the upload (SIGBUS on the
            // lost pages): say so instead.
            match volume.check_still_mapped() {
                Err(error) => {
                    scene.has_volume = false;
                    report(RenderReply::Failed(ViewError::VolumeGone(error)));
                    Ok(())
                }
                Ok(()) => scene.ray_caster.set_volume(&volume).map(|()| scene.has_volume = true),
            }
        }
        Request::Labels(labels, styles) => scene
            .ray_caster
            .set_class_table(&styles)
            .and_then(|()| scene.ray_caster.set_labels(&labels))
            .map(|()| scene.has_labels = true),
        Request::Styles(styles) => scene.ray_caster.set_class_table(&styles),
        Request::ClassOpacity(label, factor) if scene.ray_caster.class_opacity(label).is_some() => {
            scene.ray_caster.set_class_opacity(label, factor)
        }
        // Labels not yet sent: the styles that come with them carry the factor.
        Request::ClassOpacity(..) => Ok(()),
        Request::Clip(clip) => {
            scene.clip = clip;
            Ok(())
        }
        Request::Frame(request) => {
            frame = Some(request);
            Ok(())
        }
    };
    if let Err(error) = result {
        report(RenderReply::Failed(ViewError::Render(error)));
    }
    let Some(frame) = frame.filter(|_| scene.has_volume && scene.has_labels) else { return };
    if ticket.newer_sent() || ticket.cancelled() {
        // The newer request draws it once it is applied.
        scene.refining = Some((frame, Instant::now()));
        return;
    }
    match draw(scene, frame) {
        Ok(Some(picture)) => report(RenderReply::Picture(picture)),
        Ok(None) => {}
        Err(error) => report(RenderReply::Failed(error)),
    }
    while scene.refining.is_some() && !ticket.newer_sent() && !ticket.cancelled() {
        refine(scene, report);
    }
}

fn open_scene() -> Result<GpuScene, ViewError> {
    let gpu = gpu::acquire().map_err(ViewError::Unavailable)?;
    log::info!("3-D view renders on {}", gpu.adapter_name());
    let ray_caster = RayCaster::new(&gpu.device, &gpu.queue, OFFSCREEN_FORMAT).map_err(ViewError::Unavailable)?;
    let view = ProgressiveView::new(&gpu.device, &gpu.queue);
    Ok(GpuScene { ray_caster, view, refining: None, has_volume: false, has_labels: false, clip: None })
}

fn settings(clip: Option<ClipPlane>) -> RenderSettings {
    RenderSettings {
        mode: RenderMode::Postclassified,
        background: [0.0, 0.0, 0.0, 1.0],
        clip_plane: clip.filter(ClipPlane::is_usable),
        ..RenderSettings::default()
    }
}

/// Draws the next band of the full frame; sends the frame once it is whole.
fn refine(scene: &mut GpuScene, report: &Report<'_, RenderReply>) {
    let Some((FrameRequest { id, .. }, started)) = scene.refining else { return };
    match scene.view.refine(&mut scene.ray_caster) {
        Ok(None) if scene.view.refining() => {}
        Ok(None) => scene.refining = None,
        Ok(Some(image)) => {
            scene.refining = None;
            report(RenderReply::Picture(Picture { id, image, seconds: started.elapsed().as_secs_f64(), whole: true }));
        }
        Err(error) => {
            scene.refining = None;
            report(RenderReply::Failed(ViewError::Render(error)));
        }
    }
}

/// Starts the full frame, and draws its preview first when one was asked for.
fn draw(scene: &mut GpuScene, frame: FrameRequest) -> Result<Option<Picture>, ViewError> {
    let started = Instant::now();
    let settings = settings(scene.clip);
    let FrameRequest { id, camera, size, preview } = frame;
    let picture = if preview {
        let image = scene.view.preview(&mut scene.ray_caster, &camera, &settings, size).map_err(ViewError::Render)?;
        Some(Picture { id, image, seconds: started.elapsed().as_secs_f64(), whole: false })
    } else {
        None
    };
    scene.view.start_full(&camera, &settings, size);
    scene.refining = Some((frame, started));
    Ok(picture)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// A renderer holding a 24-voxel sphere of one class.
    fn sphere_renderer() -> ViewRenderer {
        let dims = [24usize; 3];
        let inside = |i: usize| {
            let p = [i % 24, (i / 24) % 24, i / 576].map(|c| c as f32 - 11.5);
            p.iter().map(|c| c * c).sum::<f32>() < 64.0
        };
        let values: Vec<f32> = (0..24 * 24 * 24).map(|i| if inside(i) { 200.0 } else { 0.0 }).collect();
        let labels: Vec<u8> = (0..values.len()).map(|i| inside(i) as u8).collect();
        let volume = Volume::from_f32(dims, [1.0; 3], &values, "sphere".as_ref()).unwrap();
        let style = ClassStyle {
            hue_degrees: [30.0, 60.0],
            saturation: 0.7,
            value: 0.9,
            opacity: [0.4, 0.8],
            gradient_max: 100.0,
            emphasis: 1.0,
            visible: true,
        };
        let mut renderer = ViewRenderer::new();
        renderer.set_volume(Arc::new(volume));
        renderer.set_labels(Arc::new(labels), vec![style]);
        renderer
    }

    /// The pictures that come back within `wait` of the first, up to `count` of them.
    fn pictures(renderer: &mut ViewRenderer, count: usize, wait: Duration) -> Vec<Picture> {
        let mut pictures = Vec::new();
        let mut deadline = Instant::now() + Duration::from_secs(120);
        while pictures.len() < count && Instant::now() < deadline {
            match renderer.poll() {
                Some(RenderReply::Picture(picture)) => {
                    pictures.push(picture);
                    deadline = deadline.min(Instant::now() + wait);
                }
                Some(RenderReply::Failed(error)) => panic!("{error}"),
                None => std::thread::sleep(Duration::from_millis(5)),
            }
        }
        pictures
    }

    /// `image` is a whole frame of `size` showing the sphere.
    fn assert_shows_the_sphere(image: &image::RgbaImage, size: [u32; 2]) {
        assert_eq!(image.dimensions(), (size[0], size[1]));
        assert!(image.pixels().filter(|p| p[0] > 60).count() > 500, "the sphere is drawn");
    }

    #[test]
    fn a_frame_comes_back_as_a_preview_then_whole() {
        let mut renderer = sphere_renderer();
        let size = [160, 100];
        let id = renderer.request_frame(Camera::default(), size);
        let pictures = pictures(&mut renderer, 2, Duration::from_secs(120));
        assert_eq!(pictures.len(), 2, "a preview and the full frame");
        assert!(pictures.iter().all(|picture| picture.id == id));
        let (preview, full) = (&pictures[0].image, &pictures[1].image);
        assert!(preview.width() < size[0], "the first preview is smaller: {:?}", preview.dimensions());
        assert_shows_the_sphere(full, size);
        assert!(!renderer.busy());
        assert!(!pictures[0].whole && pictures[1].whole && renderer.settled());
    }

    #[test]
    fn a_whole_frame_comes_back_without_a_preview() {
        let mut renderer = sphere_renderer();
        let size = [160, 100];
        let id = renderer.request_whole_frame(Camera::default(), size);
        // Anything after the whole frame would come within a second of it.
        let pictures = pictures(&mut renderer, 2, Duration::from_secs(1));
        assert_eq!(pictures.len(), 1, "the whole frame alone");
        assert!(pictures[0].id == id && pictures[0].whole);
        assert_shows_the_sphere(&pictures[0].image, size);
        assert!(!renderer.busy() && renderer.settled());
    }
}
