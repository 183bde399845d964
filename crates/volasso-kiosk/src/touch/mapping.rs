//! From a touchscreen's axis units to screen pixels: [`ScreenMapping`], with the panel's
//! mounting (rotation 0/90/180/270 and flips) from configuration.
//!
//! Device positions are normalised to `[0, 1]` on each axis, flipped, rotated, then scaled to
//! the screen, whose pixel coordinates run from `0` to `width` (Slint's logical coordinates).
//! [`ScreenMapping::unmap`] is the exact inverse, which the replay scripts use to turn screen
//! points into device units.
//!
//! Never: reads configuration files or devices; a mapping is built by whoever knows both ends.

use super::event::{AxisRange, DeviceInfo};

/// How the panel is turned relative to the screen image, clockwise, in quarter turns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Rotation {
    #[default]
    Degrees0,
    Degrees90,
    Degrees180,
    Degrees270,
}

impl Rotation {
    /// The rotation of `degrees` (0, 90, 180 or 270; negative and full turns are folded in).
    pub fn from_degrees(degrees: i32) -> Option<Rotation> {
        match degrees.rem_euclid(360) {
            0 => Some(Rotation::Degrees0),
            90 => Some(Rotation::Degrees90),
            180 => Some(Rotation::Degrees180),
            270 => Some(Rotation::Degrees270),
            _ => None,
        }
    }
}

/// What happens to a position outside the screen (a panel larger than the display, a bad
/// calibration, a corrupt recording).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OffScreen {
    /// Move it to the nearest screen edge (and still flag it).
    #[default]
    Clamp,
    /// Keep it where it is and only flag it.
    Keep,
}

/// A mapped point: where it lands and whether it was on the screen before any clamping.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MappedPoint {
    pub position: [f32; 2],
    pub on_screen: bool,
}

/// Device axis units -> screen pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct ScreenMapping {
    x: AxisRange,
    y: AxisRange,
    screen_size_px: [f32; 2],
    rotation: Rotation,
    flip_x: bool,
    flip_y: bool,
    off_screen: OffScreen,
}

impl ScreenMapping {
    /// The identity mounting: the device's axes span the screen, no rotation or flip, clamped.
    pub fn new(device: &DeviceInfo, screen_size_px: [f32; 2]) -> ScreenMapping {
        let sane = |v: f32| if v.is_finite() && v > 0.0 { v } else { 1.0 };
        ScreenMapping {
            x: device.x,
            y: device.y,
            screen_size_px: [sane(screen_size_px[0]), sane(screen_size_px[1])],
            rotation: Rotation::Degrees0,
            flip_x: false,
            flip_y: false,
            off_screen: OffScreen::Clamp,
        }
    }

    pub fn with_rotation(mut self, rotation: Rotation) -> ScreenMapping {
        self.rotation = rotation;
        self
    }

    /// Mirrors the device's own x and/or y axis (before rotation).
    pub fn with_flip(mut self, flip_x: bool, flip_y: bool) -> ScreenMapping {
        self.flip_x = flip_x;
        self.flip_y = flip_y;
        self
    }

    pub fn with_off_screen(mut self, off_screen: OffScreen) -> ScreenMapping {
        self.off_screen = off_screen;
        self
    }

    pub fn screen_size_px(&self) -> [f32; 2] {
        self.screen_size_px
    }

    /// Maps a device position to screen pixels.
    pub fn map(&self, device_position: [i32; 2]) -> MappedPoint {
        let mut u = (device_position[0] as f64 - self.x.minimum as f64) / self.x.span();
        let mut v = (device_position[1] as f64 - self.y.minimum as f64) / self.y.span();
        if self.flip_x {
            u = 1.0 - u;
        }
        if self.flip_y {
            v = 1.0 - v;
        }
        let (s, t) = match self.rotation {
            Rotation::Degrees0 => (u, v),
            Rotation::Degrees90 => (1.0 - v, u),
            Rotation::Degrees180 => (1.0 - u, 1.0 - v),
            Rotation::Degrees270 => (v, 1.0 - u),
        };
        let on_screen = (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t);
        let (s, t) = match self.off_screen {
            OffScreen::Clamp => (s.clamp(0.0, 1.0), t.clamp(0.0, 1.0)),
            OffScreen::Keep => (s, t),
        };
        let position = [(s * self.screen_size_px[0] as f64) as f32, (t * self.screen_size_px[1] as f64) as f32];
        MappedPoint { position, on_screen }
    }

    /// The device position that maps to `screen_position` (rounded, clamped to the axis
    /// ranges; NaN goes to the minimum).
    pub fn unmap(&self, screen_position: [f32; 2]) -> [i32; 2] {
        let s = screen_position[0] as f64 / self.screen_size_px[0] as f64;
        let t = screen_position[1] as f64 / self.screen_size_px[1] as f64;
        let (mut u, mut v) = match self.rotation {
            Rotation::Degrees0 => (s, t),
            Rotation::Degrees90 => (t, 1.0 - s),
            Rotation::Degrees180 => (1.0 - s, 1.0 - t),
            Rotation::Degrees270 => (1.0 - t, s),
        };
        if self.flip_x {
            u = 1.0 - u;
        }
        if self.flip_y {
            v = 1.0 - v;
        }
        let to_axis = |fraction: f64, axis: AxisRange| -> i32 {
            let value = axis.minimum as f64 + fraction * axis.span();
            let value = if value.is_nan() { axis.minimum as f64 } else { value.round() };
            value.clamp(axis.minimum as f64, axis.maximum.max(axis.minimum) as f64) as i32
        };
        [to_axis(u, self.x), to_axis(v, self.y)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn device() -> DeviceInfo {
        DeviceInfo { x: AxisRange::new(0, 1000), y: AxisRange::new(0, 500), ..DeviceInfo::virtual_touchscreen() }
    }

    #[test]
    fn identity_maps_corners_to_corners() {
        let mapping = ScreenMapping::new(&device(), [800.0, 400.0]);
        assert_eq!(mapping.map([0, 0]).position, [0.0, 0.0]);
        assert_eq!(mapping.map([1000, 500]).position, [800.0, 400.0]);
        assert_eq!(mapping.map([500, 250]).position, [400.0, 200.0]);
    }

    #[test]
    fn rotations_send_the_device_origin_to_the_expected_corner() {
        // The device's top-left corner, seen on a panel turned clockwise by a quarter turn each.
        let expected = [[0.0, 0.0], [800.0, 0.0], [800.0, 400.0], [0.0, 400.0]];
        for (degrees, corner) in [0, 90, 180, 270].into_iter().zip(expected) {
            let rotation = Rotation::from_degrees(degrees).unwrap();
            let mapping = ScreenMapping::new(&device(), [800.0, 400.0]).with_rotation(rotation);
            assert_eq!(mapping.map([0, 0]).position, corner, "{degrees} degrees");
        }
        assert_eq!(Rotation::from_degrees(-90), Some(Rotation::Degrees270));
        assert_eq!(Rotation::from_degrees(45), None);
    }

    #[test]
    fn flips_mirror_the_device_axes() {
        let mapping = ScreenMapping::new(&device(), [800.0, 400.0]).with_flip(true, false);
        assert_eq!(mapping.map([0, 0]).position, [800.0, 0.0]);
        let mapping = ScreenMapping::new(&device(), [800.0, 400.0]).with_flip(false, true);
        assert_eq!(mapping.map([0, 0]).position, [0.0, 400.0]);
    }

    #[test]
    fn unmap_inverts_map_for_every_mounting() {
        for degrees in [0, 90, 180, 270] {
            for (flip_x, flip_y) in [(false, false), (true, false), (false, true), (true, true)] {
                let mapping = ScreenMapping::new(&device(), [800.0, 400.0])
                    .with_rotation(Rotation::from_degrees(degrees).unwrap())
                    .with_flip(flip_x, flip_y);
                for raw in [[0, 0], [1000, 500], [123, 456], [999, 1]] {
                    let screen = mapping.map(raw).position;
                    assert_eq!(mapping.unmap(screen), raw, "{degrees} {flip_x} {flip_y} {raw:?}");
                }
            }
        }
    }

    #[test]
    fn off_screen_points_are_flagged_and_clamped_or_kept() {
        let clamped = ScreenMapping::new(&device(), [800.0, 400.0]);
        let point = clamped.map([-100, 600]);
        assert!(!point.on_screen);
        assert_eq!(point.position, [0.0, 400.0]);
        let kept = clamped.clone().with_off_screen(OffScreen::Keep).map([-100, 600]);
        assert!(!kept.on_screen);
        assert_eq!(kept.position, [-80.0, 480.0]);
        assert!(clamped.map([10, 10]).on_screen);
        // Extreme values and degenerate ranges stay finite.
        let degenerate = DeviceInfo { x: AxisRange::new(5, 5), ..device() };
        let mapping = ScreenMapping::new(&degenerate, [f32::NAN, 0.0]);
        let point = mapping.map([i32::MAX, i32::MIN]);
        assert!(point.position.iter().all(|v| v.is_finite()));
        assert_eq!(mapping.unmap([f32::NAN, f32::INFINITY]), [5, 500]);
    }
}
