//! The slice pictures drawn off the UI thread: the grey slice, the classification's colours
//! (features per pixel, paper §3.5) and the highlighted lassos ([`slice_picture`]) are made on
//! a painter thread, and the UI thread only turns finished pictures into Slint images.
//!
//! The newest request per panel wins: requests waiting behind a newer one for the same panel
//! are never drawn (the [`Serial`] worker skips them), and a picture that comes back after a
//! newer request was made is dropped, so a panel never shows an older state than the one asked
//! for last.
//!
//! Never: touches the UI, or blocks the caller.

use super::pictures::{Highlight, PictureError, slice_picture};
use super::worker::{Report, Serial, Supersedes, Task, Ticket, Worker};
use std::sync::Arc;
use volasso_core::segmentation::Segmenter;
use volasso_core::slices::{DisplayWindow, SliceLayout};
use volasso_core::strokes::Lasso;
use volasso_core::transfer::{ClassStyle, RgbImage};
use volasso_core::uncertainty;
use volasso_core::volume::Volume;

/// Everything one panel's picture is drawn from, owned so it can cross to the painter.
#[derive(Clone)]
pub struct PictureRequest {
    pub panel: usize,
    pub volume: Arc<Volume>,
    pub layout: SliceLayout,
    pub slice: usize,
    pub window: DisplayWindow,
    /// The label volume and the styles shown, once classified.
    pub classification: Option<(Arc<Vec<u8>>, Vec<ClassStyle>)>,
    /// Lassos to highlight, each group with its colour.
    pub highlights: Vec<(Vec<Lasso>, [u8; 3])>,
    /// The 3-D view's clip plane: what it cuts away is dimmed (clip.rs).
    pub clip: Option<volasso_core::render::ClipPlane>,
    /// Where the classifier is unsure is striped: the trained classifier and the margin below
    /// which a voxel is unsure (`uncertainty`).
    pub unsure: Option<(Arc<Segmenter>, f32)>,
}

impl PictureRequest {
    fn draw(&self) -> Result<RgbImage, PictureError> {
        let highlights: Vec<Highlight> =
            self.highlights.iter().map(|(lassos, colour)| Highlight { lassos, colour: *colour }).collect();
        let classification =
            self.classification.as_ref().map(|(labels, styles)| (labels.as_slice(), styles.as_slice()));
        let unsure = match (&self.unsure, &self.classification) {
            (Some((segmenter, threshold)), Some((labels, _))) => {
                let axis = self.layout.axis;
                uncertainty::slice_unsure(&self.volume, segmenter, labels, *threshold, axis, self.slice)
                    .map_err(|error| log::warn!("cannot mark the unsure voxels of the {axis} slice: {error}"))
                    .ok()
                    .flatten()
            }
            _ => None,
        };
        let mut picture = slice_picture(
            &self.volume,
            &self.layout,
            self.slice,
            self.window,
            classification,
            &highlights,
            unsure.as_deref(),
        )?;
        if let Some(plane) = &self.clip {
            let volume = &self.volume;
            crate::view3d::clip::dim_cut(&mut picture, &self.layout, volume.dims, volume.spacing_mm, self.slice, plane);
        }
        Ok(picture)
    }
}

/// What the painter reports: the panel and its picture.
pub type Painted = (usize, Result<RgbImage, PictureError>);

/// The UI thread's handle on the painter: a [`Serial`] worker (one `painter` thread, a
/// request waiting behind a newer one for the same panel never drawn).
pub struct SlicePainter {
    worker: Box<dyn Worker<PictureRequest, Painted>>,
    /// Per panel: the newest request's generation, and whether its picture is still awaited.
    newest: Vec<(u64, bool)>,
}

impl Default for SlicePainter {
    fn default() -> Self {
        SlicePainter::new()
    }
}

/// The painter's task: one picture.
fn paint_task() -> Task<PictureRequest, Painted> {
    Arc::new(|request: PictureRequest, _: &Ticket, report: &Report<'_, Painted>| {
        report((request.panel, request.draw()))
    })
}

impl SlicePainter {
    /// The painter on a thread of its own.
    pub fn new() -> SlicePainter {
        let supersedes: Supersedes<PictureRequest> = Arc::new(|older, newer| older.panel == newer.panel);
        SlicePainter::over(Box::new(Serial::new("painter", paint_task(), supersedes)))
    }

    /// The painter with no thread: each picture is drawn at `poll`, on the caller's thread.
    #[cfg(test)]
    pub fn inline() -> SlicePainter {
        SlicePainter::over(Box::new(crate::worker::Inline::new(paint_task())))
    }

    /// The painter over `worker` (an [`Inline`](crate::worker::Inline) one draws at `poll`, on
    /// the caller's thread).
    pub fn over(worker: Box<dyn Worker<PictureRequest, Painted>>) -> SlicePainter {
        SlicePainter { worker, newest: Vec::new() }
    }

    /// Asks for a panel's picture; returns at once.
    pub fn request(&mut self, request: PictureRequest) {
        let panel = request.panel;
        let generation = self.worker.send(request);
        if self.newest.len() <= panel {
            self.newest.resize(panel + 1, (0, false));
        }
        self.newest[panel] = (generation, true);
    }

    /// The next picture that is the newest asked for its panel, if one is ready; never blocks.
    pub fn poll(&mut self) -> Option<Painted> {
        while let Some(generation) = self.worker.ended_silently() {
            // Its drawing panicked (logged): the panel keeps what it shows, nothing is awaited.
            for newest in self.newest.iter_mut().filter(|newest| newest.0 == generation) {
                newest.1 = false;
            }
        }
        while let Some(delivery) = self.worker.poll() {
            let (panel, result) = delivery.output;
            let Some(newest) = self.newest.get_mut(panel) else { continue };
            if newest.0 == delivery.generation {
                newest.1 = false;
                return Some((panel, result));
            }
        }
        None
    }

    /// True while a panel's newest picture has not come back.
    pub fn busy(&self) -> bool {
        self.newest.iter().any(|&(_, awaited)| awaited)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volasso_core::slices::{Axis, plane_axes};

    #[test]
    fn the_newest_picture_of_each_panel_comes_back_drawn_off_the_caller_thread() {
        let volume = Arc::new(volasso_core::phantom::demo_foot().volume);
        let orientation = volume.orientation.as_ref();
        let window = DisplayWindow { center: 40.0, width: 400.0 };
        let request = |panel: usize, axis: Axis, slice: usize| PictureRequest {
            panel,
            volume: volume.clone(),
            layout: SliceLayout::new(orientation, axis),
            slice,
            window,
            classification: None,
            highlights: Vec::new(),
            clip: None,
            unsure: None,
        };
        let axes = plane_axes(orientation);
        let mut painter = SlicePainter::new();
        for slice in [10, 20, 30] {
            painter.request(request(0, axes[0], slice));
        }
        painter.request(request(1, axes[1], 5));
        assert!(painter.busy());
        let mut shown = Vec::new();
        let started = std::time::Instant::now();
        while painter.busy() && started.elapsed().as_secs() < 60 {
            match painter.poll() {
                Some((panel, result)) => shown.push((panel, result.unwrap())),
                None => std::thread::sleep(std::time::Duration::from_millis(5)),
            }
        }
        // Only the newest of panel 0 (slice 30) is shown, and panel 1's.
        assert_eq!(shown.iter().filter(|(panel, _)| *panel == 0).count(), 1, "older requests are never shown");
        assert_eq!(shown.len(), 2);
        let expected = request(0, axes[0], 30).draw().unwrap();
        let (_, picture) = shown.iter().find(|(panel, _)| *panel == 0).unwrap();
        assert_eq!(picture.pixels, expected.pixels);

        // Inline, with no thread: every request is drawn at the poll, the newest shown.
        let mut inline = SlicePainter::over(Box::new(crate::worker::Inline::new(paint_task())));
        inline.request(request(0, axes[0], 10));
        inline.request(request(0, axes[0], 30));
        let (panel, picture) = inline.poll().expect("drawn at the poll");
        assert_eq!((panel, picture.unwrap().pixels), (0, expected.pixels));
        assert!(inline.poll().is_none() && !inline.busy());
    }
}
