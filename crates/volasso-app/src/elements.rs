//! Where the app's elements are on screen, found by their accessible labels (the names touch
//! scripts tap): the DRM loop routes gestures to the 3-D view and the slices by these
//! rectangles, and the replay harness aims its taps with them.
//!
//! Never: changes the UI; it reads where things are.

use super::App;

use i_slint_backend_testing::ElementHandle;

/// A rectangle in screen pixels (Slint logical coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x: f32,
    pub y: f32,
    pub width: f32,
    pub height: f32,
}

impl Rect {
    /// The screen point at fractions `fraction` of this rectangle.
    pub fn point(&self, fraction: [f32; 2]) -> [f32; 2] {
        [self.x + fraction[0] * self.width, self.y + fraction[1] * self.height]
    }

    /// True when `point` lies inside (left and top edges included).
    pub fn contains(&self, point: [f32; 2]) -> bool {
        point[0] >= self.x && point[1] >= self.y && point[0] < self.x + self.width && point[1] < self.y + self.height
    }
}

impl App {
    /// Where the element with accessible label `label` is on screen (the first with a
    /// size), in logical pixels (the kiosk's scale factor is 1, so also screen pixels).
    pub fn element_rect(&self, label: &str) -> Option<Rect> {
        self.visible_element(label).map(|(_, rect)| rect)
    }

    /// The accessible value of the element with accessible label `label` (the first with
    /// a size), with where it is on screen: e.g. the letter at a slice's edge.
    pub fn element_value(&self, label: &str) -> Option<(Rect, String)> {
        self.visible_element(label).map(|(element, rect)| {
            (rect, element.accessible_value().map(|value| value.to_string()).unwrap_or_default())
        })
    }

    /// The first element with accessible label `label` that has a size, and where it is.
    fn visible_element(&self, label: &str) -> Option<(ElementHandle, Rect)> {
        ElementHandle::find_by_accessible_label(self.window(), label).find_map(|element| {
            let (position, size) = (element.absolute_position(), element.size());
            let rect = Rect { x: position.x, y: position.y, width: size.width, height: size.height };
            (size.width > 0.0 && size.height > 0.0).then_some((element, rect))
        })
    }
}
