//! Progressive frames: while the view moves, a preview with fewer pixels and samples, sized
//! from measured frame times to fit a budget; once it rests, the full frame, drawn in bands
//! that can be abandoned between two, so a finger never waits for a whole full frame.
//!
//! * [`FramePlanner`] keeps a cost model: seconds per unit of work, a unit being one pixel's
//!   ray at one sample per voxel (a frame's work is `pixels / step_voxels`). Every frame drawn
//!   updates it (an exponential average, so a machine that slows down is followed within a few
//!   frames). Previews draw at [`PREVIEW_STEP_FACTOR`] times the sample distance (opacity is
//!   corrected for the step, so colours stay) and at the largest size whose predicted time fits
//!   [`PREVIEW_TARGET_FRACTION`] of the budget (the rest is margin for noise), between
//!   [`MIN_PREVIEW_SCALE`] and full size per side; where even the smallest size would not fit
//!   (a slow or busy machine), samples spread further apart, up to [`MAX_PREVIEW_STEP_VOXELS`].
//!   Full frames are cut into bands of rows predicted to take [`BAND_SECONDS`] each.
//! * [`ProgressiveView`] draws with a [`RayCaster`] into offscreen targets and reads pictures
//!   back: [`ProgressiveView::preview`] at once, then [`ProgressiveView::start_full`] and
//!   [`ProgressiveView::refine`] one band per call until the full frame comes back; a new
//!   preview abandons the refinement.
//!
//! The ray caster draws a region with the rays of the whole frame, so a frame drawn in bands
//! is the frame drawn at once, pixel for pixel.
//!
//! Never: decides when the view moves (the caller says so by asking for a preview), owns a
//! thread, or scales pictures up (the UI shows a preview stretched to the view).

use super::headless::{OFFSCREEN_FORMAT, OffscreenTarget};
use super::{Camera, PixelRegion, RayCaster, RenderError, RenderSettings};
use std::time::Instant;

/// A preview's time budget on lavapipe at 1280x800 (and anywhere else).
pub const PREVIEW_BUDGET_SECONDS: f64 = 0.15;
/// The share of the budget a preview is planned to take.
pub const PREVIEW_TARGET_FRACTION: f64 = 0.6;
/// Previews sample this many times as far apart as the full frame (at least one voxel apart).
pub const PREVIEW_STEP_FACTOR: f32 = 2.0;
/// The widest sample distance of a preview, in voxels.
pub const MAX_PREVIEW_STEP_VOXELS: f32 = 4.0;
/// The smallest preview, as a fraction of the full size per side.
pub const MIN_PREVIEW_SCALE: f64 = 1.0 / 8.0;
/// The planned time of one band of a full frame: how long a new request can wait.
pub const BAND_SECONDS: f64 = 0.06;
/// Weight of the newest measurement in the cost average.
const COST_SMOOTHING: f64 = 0.5;
/// The preview scale per side before any frame was measured.
const FIRST_PREVIEW_SCALE: f64 = 0.25;

/// What to draw: the image size, the settings, and (for full frames) the bands.
#[derive(Clone, Debug, PartialEq)]
pub struct FramePlan {
    /// Width and height of the image, in pixels.
    pub size: [u32; 2],
    /// The settings to draw with (a preview's wider sample distance included).
    pub settings: RenderSettings,
    /// Horizontal bands covering the frame, top first; one band for a preview.
    pub bands: Vec<PixelRegion>,
}

impl FramePlan {
    /// Units of work of the frame (pixels per sample distance in voxels).
    pub fn work(&self) -> f64 {
        work(self.size, &self.settings)
    }
}

fn work(size: [u32; 2], settings: &RenderSettings) -> f64 {
    size[0] as f64 * size[1] as f64 / settings.step_voxels as f64
}

/// Picks preview sizes and full-frame bands from measured frame times; see the module doc.
#[derive(Clone, Debug)]
pub struct FramePlanner {
    budget_seconds: f64,
    /// Seconds per unit of work, from previews (which include their read back).
    preview_seconds_per_work: Option<f64>,
    /// Seconds per unit of work, from full frames and their bands.
    full_seconds_per_work: Option<f64>,
}

impl Default for FramePlanner {
    fn default() -> FramePlanner {
        FramePlanner::new(PREVIEW_BUDGET_SECONDS)
    }
}

impl FramePlanner {
    /// A planner for previews of at most `budget_seconds`.
    pub fn new(budget_seconds: f64) -> FramePlanner {
        FramePlanner { budget_seconds, preview_seconds_per_work: None, full_seconds_per_work: None }
    }

    /// The settings of a preview of a frame drawn with `settings`.
    pub fn preview_settings(settings: &RenderSettings) -> RenderSettings {
        let step_voxels = (settings.step_voxels * PREVIEW_STEP_FACTOR).clamp(1.0, 8.0).max(settings.step_voxels);
        RenderSettings { step_voxels, ..*settings }
    }

    /// The preview of a `full_size` frame drawn with `settings`.
    pub fn preview_plan(&self, full_size: [u32; 2], settings: &RenderSettings) -> FramePlan {
        let settings = FramePlanner::preview_settings(settings);
        let full_work = work(full_size, &settings);
        let scale = match self.preview_seconds_per_work.or(self.full_seconds_per_work) {
            Some(cost) if cost > 0.0 && full_work > 0.0 => {
                (PREVIEW_TARGET_FRACTION * self.budget_seconds / (cost * full_work)).sqrt()
            }
            _ => FIRST_PREVIEW_SCALE,
        };
        // Below the smallest size, fewer samples per ray make up the rest (work ~ 1 / step).
        let settings = if scale < MIN_PREVIEW_SCALE {
            let step_voxels = settings.step_voxels * ((MIN_PREVIEW_SCALE / scale).powi(2) as f32);
            RenderSettings {
                step_voxels: step_voxels.min(MAX_PREVIEW_STEP_VOXELS).max(settings.step_voxels),
                ..settings
            }
        } else {
            settings
        };
        let scale = scale.clamp(MIN_PREVIEW_SCALE, 1.0);
        let size = full_size.map(|side| ((side as f64 * scale).round() as u32).clamp(1, side.max(1)));
        FramePlan { size, settings, bands: vec![PixelRegion { x: 0, y: 0, width: size[0], height: size[1] }] }
    }

    /// The full frame, in bands of about [`BAND_SECONDS`] each.
    pub fn full_plan(&self, size: [u32; 2], settings: &RenderSettings) -> FramePlan {
        let size = size.map(|side| side.max(1));
        let row_work = work([size[0], 1], settings);
        let rows = match self.full_seconds_per_work.or(self.preview_seconds_per_work) {
            Some(cost) if cost > 0.0 => (BAND_SECONDS / (cost * row_work)).floor() as u32,
            _ => size[1] / 8,
        };
        let rows = rows.clamp(1, size[1]);
        let bands = (0..size[1])
            .step_by(rows as usize)
            .map(|y| PixelRegion { x: 0, y, width: size[0], height: rows.min(size[1] - y) })
            .collect();
        FramePlan { size, settings: *settings, bands }
    }

    /// Records that a preview of `work` units took `seconds`.
    pub fn record_preview(&mut self, work: f64, seconds: f64) {
        average_into(&mut self.preview_seconds_per_work, work, seconds);
    }

    /// Records that `work` units of a full frame (a band or more) took `seconds`.
    pub fn record_full(&mut self, work: f64, seconds: f64) {
        average_into(&mut self.full_seconds_per_work, work, seconds);
    }

    /// The predicted seconds of a preview of a `full_size` frame drawn with `settings`, once
    /// anything was measured.
    pub fn predicted_preview_seconds(&self, full_size: [u32; 2], settings: &RenderSettings) -> Option<f64> {
        let cost = self.preview_seconds_per_work.or(self.full_seconds_per_work)?;
        Some(cost * self.preview_plan(full_size, settings).work())
    }
}

fn average_into(average: &mut Option<f64>, work: f64, seconds: f64) {
    if !(work > 0.0 && seconds.is_finite() && seconds >= 0.0) {
        return;
    }
    let measured = seconds / work;
    *average = Some(match *average {
        Some(old) => old + COST_SMOOTHING * (measured - old),
        None => measured,
    });
}

/// A full frame being refined band by band.
struct Refinement {
    camera: Camera,
    plan: FramePlan,
    next_band: usize,
}

/// Previews and band-by-band full frames into offscreen targets; see the module doc.
pub struct ProgressiveView {
    device: wgpu::Device,
    queue: wgpu::Queue,
    planner: FramePlanner,
    preview_target: Option<OffscreenTarget>,
    full_target: Option<OffscreenTarget>,
    refinement: Option<Refinement>,
}

impl ProgressiveView {
    /// A view drawing on `device`, with a planner at the default budget and no targets yet.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> ProgressiveView {
        ProgressiveView {
            device: device.clone(),
            queue: queue.clone(),
            planner: FramePlanner::default(),
            preview_target: None,
            full_target: None,
            refinement: None,
        }
    }

    /// The cost model and budget.
    pub fn planner(&self) -> &FramePlanner {
        &self.planner
    }

    /// The cost model, to record or seed measurements.
    pub fn planner_mut(&mut self) -> &mut FramePlanner {
        &mut self.planner
    }

    /// Draws and reads back a preview of a `full_size` frame; abandons any refinement.
    pub fn preview(
        &mut self,
        ray_caster: &mut RayCaster,
        camera: &Camera,
        settings: &RenderSettings,
        full_size: [u32; 2],
    ) -> Result<image::RgbaImage, RenderError> {
        self.refinement = None;
        let plan = self.planner.preview_plan(full_size, settings);
        let started = Instant::now();
        let target = target_of_size(&mut self.preview_target, &self.device, &self.queue, plan.size)?;
        let image = target.capture(ray_caster, camera, &plan.settings)?;
        self.planner.record_preview(plan.work(), started.elapsed().as_secs_f64());
        Ok(image)
    }

    /// Begins the full frame of `size` pixels; [`refine`](Self::refine) draws it.
    pub fn start_full(&mut self, camera: &Camera, settings: &RenderSettings, size: [u32; 2]) {
        let plan = self.planner.full_plan(size, settings);
        self.refinement = Some(Refinement { camera: *camera, plan, next_band: 0 });
    }

    /// Whether a full frame is being refined.
    pub fn refining(&self) -> bool {
        self.refinement.is_some()
    }

    /// Abandons the full frame being refined.
    pub fn cancel_full(&mut self) {
        self.refinement = None;
    }

    /// Draws the next band of the full frame; returns the frame once its last band is drawn
    /// (then nothing is refined any more), `None` before, and `None` when nothing is refined.
    pub fn refine(&mut self, ray_caster: &mut RayCaster) -> Result<Option<image::RgbaImage>, RenderError> {
        let Some(refinement) = self.refinement.as_mut() else { return Ok(None) };
        let target = target_of_size(&mut self.full_target, &self.device, &self.queue, refinement.plan.size)?;
        let band = refinement.plan.bands[refinement.next_band];
        let started = Instant::now();
        let drawn = target.draw_region(ray_caster, &refinement.camera, &refinement.plan.settings, Some(band));
        if let Err(error) = drawn {
            self.refinement = None;
            return Err(error);
        }
        self.planner
            .record_full(work([band.width, band.height], &refinement.plan.settings), started.elapsed().as_secs_f64());
        refinement.next_band += 1;
        if refinement.next_band < refinement.plan.bands.len() {
            return Ok(None);
        }
        self.refinement = None;
        target.read_image().map(Some)
    }

    /// Draws and reads back a whole full frame, band by band.
    pub fn full(
        &mut self,
        ray_caster: &mut RayCaster,
        camera: &Camera,
        settings: &RenderSettings,
        size: [u32; 2],
    ) -> Result<image::RgbaImage, RenderError> {
        self.start_full(camera, settings, size);
        loop {
            if let Some(image) = self.refine(ray_caster)? {
                return Ok(image);
            }
        }
    }
}

/// The target in `slot`, made anew when it is missing or of another size.
fn target_of_size<'a>(
    slot: &'a mut Option<OffscreenTarget>,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    size: [u32; 2],
) -> Result<&'a OffscreenTarget, RenderError> {
    if slot.as_ref().is_none_or(|target| target.size() != size) {
        *slot = Some(OffscreenTarget::new(device, queue, size[0], size[1], OFFSCREEN_FORMAT)?);
    }
    slot.as_ref().ok_or(RenderError::BadSetting {
        name: "image size",
        value: format!("{}x{}", size[0], size[1]),
        expected: "a target that could be made",
    })
}

#[cfg(test)]
#[path = "progressive_tests.rs"]
mod tests;
