//! The slice pictures drawn off the UI thread: the grey slice, the classification's colours
//! (features per pixel, paper §3.5) and the highlighted lassos ([`slice_picture`]) are made on
//! a painter thread, and the UI thread only turns finished pictures into Slint images.
//!
//! The newest request per panel wins: requests waiting behind a newer one for the same panel
//! are never drawn, and a picture that comes back after a newer request was made is dropped,
//! so a panel never shows an older state than the one asked for last.
//!
//! Never: touches the UI, or blocks the caller.

use super::pictures::{Highlight, PictureError, slice_picture};
use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use volasso_core::segmentation::{Segmenter, uncertainty};
use volasso_core::slices::{DisplayWindow, SliceLayout};
use volasso_core::strokes::Lasso;
use volasso_core::transfer::{ClassStyle, RgbImage};
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
    /// which a voxel is unsure (`segmentation::uncertainty`).
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

struct Reply {
    panel: usize,
    generation: u64,
    result: Result<RgbImage, PictureError>,
}

/// The UI thread's handle on the painter thread.
pub struct SlicePainter {
    requests: Option<Sender<(u64, PictureRequest)>>,
    replies: Receiver<Reply>,
    sender: Sender<Reply>,
    next_generation: u64,
    /// Per panel: the newest request's generation, and whether its picture is still awaited.
    newest: Vec<(u64, bool)>,
}

impl Default for SlicePainter {
    fn default() -> Self {
        SlicePainter::new()
    }
}

impl SlicePainter {
    /// Starts the painter thread; when it cannot start, pictures are drawn on the caller's
    /// thread (slower, but every panel is still shown).
    pub fn new() -> SlicePainter {
        let (sender, replies) = channel();
        let (requests, received) = channel();
        let to_ui = sender.clone();
        let started = std::thread::Builder::new()
            .name("painter".into())
            .spawn(move || paint_thread(received, to_ui))
            .map_err(|error| log::error!("cannot start the painter thread, drawing slices on the UI thread: {error}"))
            .is_ok();
        SlicePainter { requests: started.then_some(requests), replies, sender, next_generation: 0, newest: Vec::new() }
    }

    /// Asks for a panel's picture; returns at once.
    pub fn request(&mut self, request: PictureRequest) {
        self.next_generation += 1;
        let generation = self.next_generation;
        if self.newest.len() <= request.panel {
            self.newest.resize(request.panel + 1, (0, false));
        }
        self.newest[request.panel] = (generation, true);
        let unsent = match &self.requests {
            Some(requests) => match requests.send((generation, request)) {
                Ok(()) => return,
                Err(error) => error.0.1,
            },
            None => request,
        };
        let _ = self.sender.send(Reply { panel: unsent.panel, generation, result: unsent.draw() });
    }

    /// The next picture that is the newest asked for its panel, if one is ready; never blocks.
    pub fn poll(&mut self) -> Option<(usize, Result<RgbImage, PictureError>)> {
        loop {
            let reply = match self.replies.try_recv() {
                Ok(reply) => reply,
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return None,
            };
            let Some(newest) = self.newest.get_mut(reply.panel) else { continue };
            if newest.0 == reply.generation {
                newest.1 = false;
                return Some((reply.panel, reply.result));
            }
        }
    }

    /// True while a panel's newest picture has not come back.
    pub fn busy(&self) -> bool {
        self.newest.iter().any(|&(_, awaited)| awaited)
    }
}

fn paint_thread(requests: Receiver<(u64, PictureRequest)>, replies: Sender<Reply>) {
    while let Ok(first) = requests.recv() {
        let mut waiting = vec![first];
        waiting.extend(requests.try_iter());
        for (index, (generation, request)) in waiting.iter().enumerate() {
            let superseded = waiting[index + 1..].iter().any(|(_, later)| later.panel == request.panel);
            if superseded {
                continue;
            }
            let result = request.draw();
            if replies.send(Reply { panel: request.panel, generation: *generation, result }).is_err() {
                return;
            }
        }
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
    }
}
