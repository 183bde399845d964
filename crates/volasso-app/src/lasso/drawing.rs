//! A finger path on a slice picture, turned into what it meant: a lasso (a closed polygon in
//! the slice's image coordinates, the strokes file's convention), a horizontal swipe to the
//! next- or previous-ranked slice, or something the app cannot interpret, which the user is
//! told about ([`Unclear::message`]), never silently dropped. This is the one place that
//! decides; `touch::gestures` only separates taps, drags and two-finger gestures.
//!
//! The decision is by the path's *shape*, measured in screen pixels (finger scale, the same
//! whether the slice is small or enlarged and zoomed), never by its direction:
//! * a **loop** returns near its start relative to its size (the gap from end to start is at
//!   most [`CLOSE_FRACTION`] of the larger side of its bounding box) and encloses area (at
//!   least [`LOOP_MIN_FILL`] of that box, and [`LOOP_MIN_AREA_PX`]); so a flat band drawn
//!   right, down a little, back left and up is a loop, however fast;
//! * a **swipe** is open, nearly straight (its chord at least [`SWIPE_MIN_STRAIGHTNESS`] of
//!   its length), long ([`SWIPE_MIN_PX`]), fast ([`SWIPE_MIN_SPEED_PX_PER_S`]) and mostly
//!   horizontal;
//! * a tap, a slow or bent open stroke, a scribble that encloses nothing, or a loop around
//!   less than a voxel is [`PathMeaning::Unclear`].
//!
//! A shaking fingertip or a jittery panel sends points a few pixels to and fro, which cross the
//! path over itself in tiny curls and, where it runs along itself, again and again: the loops
//! within a path are found on a steadied copy of it ([`STEADY_REACH_PX`]) and drawn through the
//! points the finger gave, without the tremor's curls.
//!
//! A finger that loses the glass for a moment (a dry fingertip skips) and lands again where it
//! left goes on with the same path ([`FingerPath::resumed_or_new`]), so a loop drawn in two
//! strokes is one loop.
//!
//! Coordinates: the UI reports points as fractions of the picture *as shown*, which
//! [`SliceLayout`] arranges in the radiological convention (flipped or turned by quarter
//! turns). A lasso's vertices go through the layout's inverse, so the lasso holds the voxels
//! under the finger whatever the flips.
//!
//! Never: touches the UI or the volume.

use crate::lasso::path_loops::{enclosed_area, loops_within, steadied, uncurled};
use volasso_core::slices::{Axis, SliceGeometry, SliceLayout};
use volasso_core::strokes::Lasso;

/// How near (screen pixels) the neighbours a point is averaged with lie, on the path the loops
/// within it are found on (`path_loops::steadied`): a fingertip's tremor and a panel's jitter, a few
/// pixels to and fro between reports, would otherwise cross the path over itself again and
/// again. A third of a fingertip's width; a loop within a path smaller than that is not one a
/// finger can draw. Random jitter of 4 px (standard deviation) between reports 1.5 px apart
/// leaves every loop of `a_loop_drawn_with_a_shaking_finger_keeps_all_it_circled`'s kinds
/// whole at 12 px; at 6 px half of them are lost, at 3 px of jitter none at either.
pub const STEADY_REACH_PX: f32 = 12.0;

/// Points closer than this (screen pixels) to the previous one are dropped: a finger resting on
/// the glass sends many.
const MIN_STEP_PX: f32 = 1.5;

/// A path keeps at most this many points, so a touch storm cannot grow it without bound.
pub const MAX_PATH_POINTS: usize = 4096;

/// A path within this many pixels of where it started is a tap; the touch gesture recogniser's
/// slop is this value.
pub const TAP_EXTENT_PX: f32 = 12.0;

/// A loop ends within this fraction of its bounding box's larger side from its start.
pub const CLOSE_FRACTION: f32 = 0.35;
/// A loop encloses at least this fraction of its bounding box (a circle 0.79, a flat band
/// nearly 1, a scribble back and forth nearly 0)...
pub const LOOP_MIN_FILL: f32 = 0.15;
/// ...and at least this many square pixels.
pub const LOOP_MIN_AREA_PX: f32 = 64.0;

/// A swipe's chord is at least this fraction of its length (nearly straight)...
pub const SWIPE_MIN_STRAIGHTNESS: f32 = 0.85;
/// ...at least this long...
pub const SWIPE_MIN_PX: f32 = 40.0;
/// ...covered at least this fast (a flick is 1000 px/s and more; drawing is slower)...
pub const SWIPE_MIN_SPEED_PX_PER_S: f32 = 400.0;
/// ...and at least this many times wider than tall.
pub const SWIPE_MIN_ASPECT: f32 = 2.0;

/// A finger that left the glass for a moment (a dry fingertip skipping, or lifted and put back
/// to go on) and lands again within this time...
pub const RESUME_WITHIN_MS: f64 = 500.0;
/// ...and this many screen pixels (a fingertip's width) of where its path broke off open goes
/// on with the same path.
pub const RESUME_WITHIN_PX: f32 = 48.0;

/// A path cut off by a second finger after this many screen pixels was a loop being drawn,
/// not the first finger of a pinch (which moves a few pixels before the second lands).
pub const INTERRUPTED_MIN_PX: f32 = 60.0;

/// The finger path on one slice picture.
#[derive(Clone, Debug, PartialEq)]
pub struct FingerPath {
    /// The points, in fractions (0..1) of the picture's width and height as shown.
    pub points: Vec<[f32; 2]>,
    /// The picture's size on screen when the finger landed, in pixels.
    picture_px: [f32; 2],
    /// When the first and the last point came, in milliseconds of the UI clock.
    start_ms: f64,
    end_ms: f64,
}

/// What a finished path meant.
#[derive(Clone, Debug, PartialEq)]
pub enum PathMeaning {
    Lasso(Lasso),
    /// +1: to the next-ranked slice (a swipe to the left, like turning a page); -1: back.
    Swipe(i32),
    Unclear(Unclear),
}

/// Why a path was neither a loop nor a swipe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unclear {
    /// The finger hardly moved.
    Tap,
    /// It did not come back near its start, and was not a quick straight sideways swipe.
    Open,
    /// It came back but enclosed (almost) nothing: a line drawn back and forth.
    NoArea,
    /// The loop holds no voxel centre.
    TooSmall,
    /// The slice is not in the volume (it changed under the finger).
    NoSlice,
    /// A second finger (a palm, the other hand) touched the same slice while the path was drawn.
    Interrupted,
}

impl Unclear {
    /// What the user is told.
    pub fn message(self) -> &'static str {
        match self {
            Unclear::Tap | Unclear::NoSlice => "Draw a closed loop around the structure",
            Unclear::Open => {
                "Draw a closed loop around the structure: the path did not come back to its start (swipe quickly sideways to change the slice)"
            }
            Unclear::NoArea => "Draw a closed loop around the structure: the path enclosed no area",
            Unclear::TooSmall => "Draw a closed loop around the structure: this loop holds no whole voxel",
            Unclear::Interrupted => "A second touch interrupted the loop: draw it again with one finger",
        }
    }
}

impl FingerPath {
    /// A path starting at `fraction` of a picture shown `picture_px` pixels large, at `time_ms`.
    pub fn new(picture_px: [f32; 2], fraction: [f32; 2], time_ms: f64) -> FingerPath {
        let picture_px = picture_px.map(|side| if side.is_finite() && side >= 1.0 { side } else { 1.0 });
        let time_ms = if time_ms.is_finite() { time_ms } else { 0.0 };
        let mut path = FingerPath { points: Vec::new(), picture_px, start_ms: time_ms, end_ms: time_ms };
        path.add(fraction, time_ms);
        path
    }

    /// The path a finger landing at `fraction` of a picture shown `picture_px` large at
    /// `time_ms` draws: `broken_off` going on, when it broke off open on the same picture within
    /// [`RESUME_WITHIN_MS`] and [`RESUME_WITHIN_PX`] of here; else a new path.
    pub fn resumed_or_new(
        broken_off: Option<FingerPath>,
        picture_px: [f32; 2],
        fraction: [f32; 2],
        time_ms: f64,
    ) -> FingerPath {
        let landing = FingerPath::new(picture_px, fraction, time_ms);
        let Some(mut path) = broken_off else { return landing };
        let (Some(&left_at), Some(&landed_at)) = (path.points.last(), landing.points.first()) else { return landing };
        let [dx, dy] = path.to_px([landed_at[0] - left_at[0], landed_at[1] - left_at[1]]);
        let away_ms = landing.start_ms - path.end_ms;
        if path.picture_px != landing.picture_px
            || !(0.0..=RESUME_WITHIN_MS).contains(&away_ms)
            || dx.hypot(dy) > RESUME_WITHIN_PX
        {
            return landing;
        }
        path.add(landed_at, landing.start_ms);
        path
    }

    /// What a path cut off by a second finger on its slice (the touch cancelled: two fingers
    /// pinch or pan) is told: nothing for a finger that had hardly moved (the first finger of a
    /// pinch), else [`Unclear::Interrupted`], so a loop is never lost without a word.
    pub fn cancelled(&self) -> Option<Unclear> {
        (Shape::of(&self.on_screen()).length >= INTERRUPTED_MIN_PX).then_some(Unclear::Interrupted)
    }

    pub fn add(&mut self, fraction: [f32; 2], time_ms: f64) {
        if !(fraction[0].is_finite() && fraction[1].is_finite()) || self.points.len() >= MAX_PATH_POINTS {
            return;
        }
        if time_ms.is_finite() && time_ms >= self.end_ms {
            self.end_ms = time_ms;
        }
        if let Some(&last) = self.points.last() {
            let [dx, dy] = self.to_px([fraction[0] - last[0], fraction[1] - last[1]]);
            if dx.abs().max(dy.abs()) < MIN_STEP_PX {
                return;
            }
        }
        self.points.push(fraction);
    }

    /// The path as an SVG path in a 0..1000 box, closed while drawing so the user sees what
    /// the lasso will enclose.
    pub fn svg_commands(&self) -> String {
        let mut commands = String::with_capacity(self.points.len() * 14);
        for (k, [x, y]) in self.points.iter().enumerate() {
            let verb = if k == 0 { 'M' } else { 'L' };
            commands.push_str(&format!("{verb} {:.1} {:.1} ", x * 1000.0, y * 1000.0));
        }
        if self.points.len() > 2 {
            commands.push('Z');
        }
        commands
    }

    fn to_px(&self, fraction: [f32; 2]) -> [f32; 2] {
        [fraction[0] * self.picture_px[0], fraction[1] * self.picture_px[1]]
    }

    /// The path's points in screen pixels.
    fn on_screen(&self) -> Vec<[f32; 2]> {
        self.points.iter().map(|&p| self.to_px(p)).collect()
    }

    /// What the path meant on slice `slice` along `layout.axis` of a volume of `dims`, shown
    /// as `layout` arranges it (module doc).
    pub fn meaning(&self, dims: [usize; 3], layout: &SliceLayout, slice: usize) -> PathMeaning {
        let axis: Axis = layout.axis;
        if SliceGeometry::new(dims, axis, slice).is_none() {
            return PathMeaning::Unclear(Unclear::NoSlice);
        }
        // Without a tremor's curls, which would be holes or specks under the even-odd rule.
        let on_screen = uncurled(&self.on_screen(), LOOP_MIN_AREA_PX);
        let shape = Shape::of(&on_screen);
        if shape.extent < TAP_EXTENT_PX {
            return PathMeaning::Unclear(Unclear::Tap);
        }
        let closed = shape.gap <= CLOSE_FRACTION * shape.extent;
        // The whole path (when it came back near its start) and the loops within it, in screen
        // pixels: found on the steadied path, so that tremor does not cross it over itself, and
        // drawn through the points the finger gave.
        let steady = steadied(&on_screen, STEADY_REACH_PX);
        let mut candidates: Vec<Vec<[f32; 2]>> = loops_within(&steady, closed, CLOSE_FRACTION, LOOP_MIN_AREA_PX)
            .iter()
            .map(|within| within.on(&on_screen))
            .collect();
        if closed {
            candidates.insert(0, on_screen);
        }
        candidates.retain(|candidate| {
            let own = Shape::of(candidate);
            own.area >= LOOP_MIN_AREA_PX
                && own.area >= LOOP_MIN_FILL * own.box_area
                && own.area >= LOOP_MIN_FILL * shape.box_area
        });
        // Voxel centres at whole numbers: the shown picture spans -0.5 .. size - 0.5.
        let [width, height] = layout.screen_size(dims).map(|side| side as f64);
        let [picture_width, picture_height] = self.picture_px.map(f64::from);
        let lassos = candidates.iter().map(|candidate| {
            let points = candidate
                .iter()
                .map(|&[x, y]| {
                    let fraction = [f64::from(x) / picture_width, f64::from(y) / picture_height];
                    layout.image_from_screen([fraction[0] * width - 0.5, fraction[1] * height - 0.5], dims)
                })
                .collect::<Vec<_>>();
            let lasso = Lasso { axis, slice, points };
            (lasso.selected_voxels(dims).len(), lasso)
        });
        // The loop that holds the most: a region circled twice is in it, a lobe is not lost.
        let mut best: Option<(usize, Lasso)> = None;
        for (count, lasso) in lassos {
            if best.as_ref().is_none_or(|(most, _)| count > *most) {
                best = Some((count, lasso));
            }
        }
        match best {
            Some((0, _)) => return PathMeaning::Unclear(Unclear::TooSmall),
            Some((_, lasso)) => return PathMeaning::Lasso(lasso),
            None if closed => return PathMeaning::Unclear(Unclear::NoArea),
            None => {}
        }
        let seconds = ((self.end_ms - self.start_ms) / 1000.0).max(1e-3) as f32;
        let swipe = shape.chord[0].abs() >= SWIPE_MIN_ASPECT * shape.chord[1].abs()
            && shape.gap >= SWIPE_MIN_PX
            && shape.gap >= SWIPE_MIN_STRAIGHTNESS * shape.length
            && shape.gap / seconds >= SWIPE_MIN_SPEED_PX_PER_S;
        if swipe {
            return PathMeaning::Swipe(if shape.chord[0] < 0.0 { 1 } else { -1 });
        }
        PathMeaning::Unclear(Unclear::Open)
    }
}

/// A path's measurements in screen pixels.
#[derive(Clone, Copy, Debug)]
struct Shape {
    /// From the first point to the last.
    chord: [f32; 2],
    /// The chord's length: how far the end is from the start.
    gap: f32,
    length: f32,
    /// The larger side of the bounding box, and the box's area.
    extent: f32,
    box_area: f32,
    /// The area the path encloses when closed by the chord ([`enclosed_area`]).
    area: f32,
}

impl Shape {
    fn of(points: &[[f32; 2]]) -> Shape {
        let (Some(&first), Some(&last)) = (points.first(), points.last()) else {
            return Shape { chord: [0.0; 2], gap: 0.0, length: 0.0, extent: 0.0, box_area: 0.0, area: 0.0 };
        };
        let (mut low, mut high) = (first, first);
        for point in points {
            for a in 0..2 {
                low[a] = low[a].min(point[a]);
                high[a] = high[a].max(point[a]);
            }
        }
        let chord = [last[0] - first[0], last[1] - first[1]];
        let length = points.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sum();
        let size = [high[0] - low[0], high[1] - low[1]];
        Shape {
            chord,
            gap: chord[0].hypot(chord[1]),
            length,
            extent: size[0].max(size[1]),
            box_area: size[0] * size[1],
            area: enclosed_area(points),
        }
    }
}

#[cfg(test)]
#[path = "drawing_tests.rs"]
mod tests;
