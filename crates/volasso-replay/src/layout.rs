//! Whether a screen's controls are usable by a finger on this panel: every button and slider
//! lies whole inside the window, none overlaps another, and each is at least a touch target
//! (9 mm, `app::dpi`) on both sides at the UI's density. Replay scripts ask for it with
//! `expect layout 9mm` on each screen, at each panel size.
//!
//! What counts: the elements whose accessible role is button or slider, as the UI's
//! accessibility tree reports them (the names scripts tap). A control inside a scrolling list
//! (a `Flickable`) counts for the part the list shows, and may be cut by the list's edge (that
//! is scrolling, not a cut-off control). A control that covers nearly the whole window (the
//! start screen's "touch anywhere") is a background, not a target. Controls under the error
//! banner (those it covers that are not its own) are covered on purpose until it is
//! dismissed, and are not counted.
//!
//! Never: changes the UI; it reads where things are.

use crate::app::App;
use crate::touch::script::Rect;
use i_slint_backend_testing::{AccessibleRole, ElementHandle, ElementQuery};

/// One control on screen.
#[derive(Clone, Debug, PartialEq)]
pub struct Control {
    pub label: String,
    /// Where it is, clipped to the scrolling list that holds it.
    pub rect: Rect,
    /// Cut by the edge of its scrolling list.
    pub scrolled: bool,
    /// Part of the error banner (its Dismiss button).
    pub on_banner: bool,
}

/// A control covering more than this share of the window is a background.
const BACKGROUND_SHARE: f32 = 0.9;
/// Overlaps and overhangs below this many pixels are rounding.
const TOLERANCE_PX: f32 = 0.5;

/// The buttons and sliders of `app`'s window, and the error banner's rectangle if one shows.
pub fn controls(app: &App) -> (Vec<Control>, Option<Rect>) {
    let window = app.window();
    let lists: Vec<(Rect, Vec<(String, Rect)>)> = ElementQuery::from_root(window)
        .match_type_name("Flickable")
        .find_all()
        .iter()
        .map(|list| (rect_of(list), targets(|| list.query_descendants())))
        .collect();
    let banner = ElementHandle::find_by_accessible_label(window, "banner")
        .find(|element| element.size().width > 0.0 && element.size().height > 0.0);
    let on_banner = banner.as_ref().map_or(Vec::new(), |banner| targets(|| banner.query_descendants()));
    let controls = targets(|| ElementQuery::from_root(window))
        .into_iter()
        .map(|(label, rect)| {
            let on_banner = on_banner.iter().any(|(l, r)| *l == label && *r == rect);
            let list = lists.iter().find(|(_, inside)| inside.iter().any(|(l, r)| *l == label && *r == rect));
            let (shown, scrolled) = match list.map(|(viewport, _)| intersection(rect, *viewport)) {
                Some(Some(shown)) => (shown, shown != rect),
                Some(None) => (Rect { width: 0.0, height: 0.0, ..rect }, true),
                None => (rect, false),
            };
            Control { label, rect: shown, scrolled, on_banner }
        })
        .filter(|control| control.rect.width > 0.0 && control.rect.height > 0.0)
        .collect();
    (controls, banner.as_ref().map(rect_of))
}

/// The buttons and sliders `query` finds, with their labels and rectangles.
fn targets(query: impl Fn() -> ElementQuery) -> Vec<(String, Rect)> {
    [AccessibleRole::Button, AccessibleRole::Slider]
        .into_iter()
        .flat_map(|role| query().match_accessible_role(role).find_all())
        .map(|element| (element.accessible_label().map(|l| l.to_string()).unwrap_or_default(), rect_of(&element)))
        .collect()
}

fn rect_of(element: &ElementHandle) -> Rect {
    let (position, size) = (element.absolute_position(), element.size());
    Rect { x: position.x, y: position.y, width: size.width, height: size.height }
}

fn intersection(a: Rect, b: Rect) -> Option<Rect> {
    let (left, top) = (a.x.max(b.x), a.y.max(b.y));
    let (right, bottom) = ((a.x + a.width).min(b.x + b.width), (a.y + a.height).min(b.y + b.height));
    (right > left && bottom > top).then_some(Rect { x: left, y: top, width: right - left, height: bottom - top })
}

/// What is wrong with `controls` in a window of `window` pixels, for targets of at least
/// `min_side` pixels, with `banner` covering what lies under it: one line per problem.
pub fn problems(controls: &[Control], window: [f32; 2], min_side: f32, banner: Option<Rect>) -> Vec<String> {
    let screen = Rect { x: 0.0, y: 0.0, width: window[0], height: window[1] };
    let within = |inner: Rect, outer: Rect| {
        inner.x >= outer.x - TOLERANCE_PX
            && inner.y >= outer.y - TOLERANCE_PX
            && inner.x + inner.width <= outer.x + outer.width + TOLERANCE_PX
            && inner.y + inner.height <= outer.y + outer.height + TOLERANCE_PX
    };
    let counted: Vec<&Control> = controls
        .iter()
        .filter(|c| c.rect.width * c.rect.height < BACKGROUND_SHARE * window[0] * window[1])
        .filter(|c| match banner {
            Some(banner) => c.on_banner || intersection(c.rect, banner).is_none(),
            None => true,
        })
        .collect();
    let mut found = Vec::new();
    for control in &counted {
        let Rect { x, y, width, height } = control.rect;
        if !within(control.rect, screen) {
            found.push(format!("'{}' at {x:.0},{y:.0} {width:.0}x{height:.0} is cut off by the window", control.label));
        }
        if !control.scrolled && width.min(height) + TOLERANCE_PX < min_side {
            found.push(format!("'{}' is {width:.0}x{height:.0} px, under {min_side:.0} px", control.label));
        }
    }
    for (i, a) in counted.iter().enumerate() {
        for b in &counted[i + 1..] {
            if let Some(overlap) = intersection(a.rect, b.rect)
                && overlap.width > TOLERANCE_PX
                && overlap.height > TOLERANCE_PX
            {
                found.push(format!(
                    "'{}' overlaps '{}' by {:.0}x{:.0} px",
                    a.label, b.label, overlap.width, overlap.height
                ));
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn control(label: &str, x: f32, y: f32, width: f32, height: f32) -> Control {
        Control { label: label.into(), rect: Rect { x, y, width, height }, scrolled: false, on_banner: false }
    }

    #[test]
    fn whole_apart_and_large_controls_pass() {
        let controls = [control("A", 8.0, 8.0, 56.0, 56.0), control("B", 72.0, 8.0, 120.0, 56.0)];
        assert_eq!(problems(&controls, [800.0, 480.0], 53.0, None), Vec::<String>::new());
    }

    #[test]
    fn overlaps_cut_offs_and_small_targets_are_each_named() {
        let controls = [
            control("Define class", 700.0, 400.0, 120.0, 56.0),
            control("Undo", 650.0, 420.0, 60.0, 56.0),
            control("Hide Class 1", 10.0, 10.0, 40.0, 56.0),
        ];
        let found = problems(&controls, [800.0, 480.0], 53.0, None);
        assert_eq!(
            found,
            [
                "'Define class' at 700,400 120x56 is cut off by the window",
                "'Hide Class 1' is 40x56 px, under 53 px",
                "'Define class' overlaps 'Undo' by 10x36 px",
            ]
        );
    }

    #[test]
    fn backgrounds_scrolled_rows_and_what_the_banner_covers_are_not_counted() {
        let banner = Rect { x: 80.0, y: 380.0, width: 640.0, height: 90.0 };
        let mut scrolled = control("Hide Class 3", 600.0, 300.0, 56.0, 20.0);
        scrolled.scrolled = true;
        let mut dismiss = control("Dismiss", 600.0, 390.0, 100.0, 56.0);
        dismiss.on_banner = true;
        let controls = [
            control("Start", 0.0, 0.0, 800.0, 480.0),
            dismiss,
            control("Template V", 560.0, 400.0, 60.0, 56.0),
            scrolled,
        ];
        assert_eq!(problems(&controls, [800.0, 480.0], 53.0, Some(banner)), Vec::<String>::new());
        // Without the banner, the button under it is a target again, and overlaps Dismiss.
        let found = problems(&controls, [800.0, 480.0], 53.0, None);
        assert_eq!(found, ["'Dismiss' overlaps 'Template V' by 20x46 px"]);
    }
}
