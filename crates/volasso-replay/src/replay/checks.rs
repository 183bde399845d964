//! What a replay script's `expect KEY VALUE` lines check, on the harness's screen and app.
//!
//! Expectations compare [`App::query`](crate::app::App::query) keys, plus:
//! * `view-colours N`: the 3-D view shows at least N distinct hues;
//! * `view-differs NAME`: the 3-D view changed since the screenshot NAME (a mean difference
//!   over one level, or 1 % of its pixels changed by more than 16 levels);
//! * `view-matches NAME`: the 3-D view is as in the screenshot NAME (mean difference under one
//!   level);
//! * `screen-differs NAME`: the whole screen differs from the screenshot NAME;
//! * `element NAME`: an element with that accessible label is on screen;
//! * `layout 9mm`: every button and slider on screen is whole, overlaps no other and is at
//!   least 9 mm on each side at the UI's density (kiosk::layout);
//! * `letters ELEMENT TOP,RIGHT,BOTTOM,LEFT`: the patient letters shown at the four edges of a
//!   slice, clockwise from the top, e.g. `expect letters "slice z" A,L,P,R` (each read from the
//!   screen's accessibility tree, and it must lie at its edge of the part of the slice on
//!   screen);
//! * `snapshots N`: the data folder's `snapshots/` holds N PNGs, the newest one of the 3-D
//!   view's picture size;
//! * `view-steady SECONDS`: waits, in real time, until the 3-D view stops changing (a
//!   progressive frame is whole);
//! * `same-result NAME`: the app's result ([`App::result_digest`](crate::app::App::result_digest):
//!   volume, classes, labels and camera, and the 3-D view's pixels) equals that at the
//!   screenshot NAME.
//!
//! Never: touches or waits, other than `view-steady`'s wait for the 3-D view.

use crate::app::dpi;
use crate::harness::Harness;
use crate::layout;
use crate::touch::script::{Rect, expectations};
use crate::transfer::RgbImage;
use std::collections::HashMap;
use std::time::{Duration, Instant};

pub(super) fn expect(
    harness: &mut Harness,
    taken: &HashMap<String, RgbImage>,
    key: &str,
    value: &str,
) -> Result<(), String> {
    match key {
        "view-colours" => {
            let wanted: usize = value.parse().map_err(|_| format!("view-colours wants a count, not '{value}'"))?;
            let screen = harness.screenshot();
            let view = view_pixels(harness, &screen)?;
            let hues = distinct_hues(&view);
            if hues >= wanted {
                Ok(())
            } else {
                Err(format!("the 3-D view shows {hues} distinct hues, expected at least {wanted}"))
            }
        }
        "view-differs" => {
            let earlier = taken.get(value).ok_or(format!("no screenshot named '{value}' was taken"))?;
            let screen = harness.screenshot();
            let (now, then) = (view_pixels(harness, &screen)?, view_pixels(harness, earlier)?);
            let (difference, changed) = (mean_difference(&now, &then), changed_share(&now, &then));
            // A small structure on a wide black view changes few pixels but changes them a
            // lot: either measure says the view moved.
            if difference > 1.0 || changed >= MIN_CHANGED_SHARE {
                Ok(())
            } else {
                Err(format!(
                    "the 3-D view is unchanged since '{value}' (mean difference {difference:.2} levels, {:.2} % of its \
                     pixels changed by more than {CHANGED_LEVELS} levels)",
                    100.0 * changed
                ))
            }
        }
        "view-matches" => {
            let earlier = taken.get(value).ok_or(format!("no screenshot named '{value}' was taken"))?;
            let screen = harness.screenshot();
            let (now, then) = (view_pixels(harness, &screen)?, view_pixels(harness, earlier)?);
            let difference = mean_difference(&now, &then);
            if difference < 1.0 {
                Ok(())
            } else {
                Err(format!("the 3-D view differs from '{value}' (mean difference {difference:.2} levels)"))
            }
        }
        "snapshots" => expect_snapshots(harness, value),
        "screen-differs" => {
            let earlier = taken.get(value).ok_or(format!("no screenshot named '{value}' was taken"))?;
            let screen = harness.screenshot();
            let difference = mean_difference(&pixels_of(&screen), &pixels_of(earlier));
            if difference > 0.2 {
                Ok(())
            } else {
                Err(format!("the screen is unchanged since '{value}' (mean difference {difference:.3} levels)"))
            }
        }
        "element" => harness.element_rect(value).map(|_| ()).ok_or(format!("no element '{value}' on screen")),
        "letters" => expect_letters(harness, value),
        "layout" => expect_layout(harness, value),
        key if expectations::KEYS.contains(&key) => {
            let (volume, labels, strokes) = harness.app().classification().ok_or("nothing is classified yet")?;
            expectations::check(key, value, &volume, &labels, &strokes)
        }
        _ => {
            let found = harness.app().query(key).ok_or(format!("unknown expectation key '{key}'"))?;
            if found == value { Ok(()) } else { Err(format!("{key} is '{found}', expected '{value}'")) }
        }
    }
}

/// `expect layout 9mm` (module doc): every control on screen whole, apart from the others and
/// at least that many millimetres on each side at the UI's density.
fn expect_layout(harness: &mut Harness, value: &str) -> Result<(), String> {
    let millimetres: f32 = value
        .strip_suffix("mm")
        .and_then(|mm| mm.trim().parse().ok())
        .filter(|mm: &f32| mm.is_finite() && *mm > 0.0)
        .ok_or(format!("layout wants a size such as 9mm, not '{value}'"))?;
    // The layout as drawn now.
    harness.screenshot();
    let dpi = harness.app().dpi();
    let (controls, banner) = layout::controls(harness.app());
    let window = harness.size().map(|side| side as f32);
    let problems = layout::problems(&controls, window, dpi::mm_to_pixels(millimetres, dpi), banner);
    if controls.is_empty() {
        return Err("no controls on screen".into());
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!("{} controls at {dpi:.0} dpi: {}", controls.len(), problems.join("; ")))
    }
}

/// `expect snapshots N` (module doc).
fn expect_snapshots(harness: &Harness, value: &str) -> Result<(), String> {
    let wanted: usize = value.parse().map_err(|_| format!("snapshots wants a count, not '{value}'"))?;
    let files = harness.app().snapshot_files();
    if files.len() != wanted {
        return Err(format!("{} snapshots in the data folder, expected {wanted}: {files:?}", files.len()));
    }
    let Some(newest) = files.iter().max_by_key(|path| std::fs::metadata(path).and_then(|m| m.modified()).ok()) else {
        return Ok(());
    };
    let size =
        image::image_dimensions(newest).map_err(|error| format!("{} is not a PNG: {error}", newest.display()))?;
    let view = harness.app().view_picture_size().ok_or("the 3-D view shows no picture")?;
    if [size.0, size.1] == view {
        Ok(())
    } else {
        Err(format!("{} is {}x{}, the 3-D view's picture {}x{}", newest.display(), size.0, size.1, view[0], view[1]))
    }
}

/// Every pixel of a screenshot.
fn pixels_of(image: &RgbImage) -> Vec<[u8; 3]> {
    image.pixels.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect()
}

/// `expect view-steady SECONDS`: frames run (the clock following real time) until the 3-D view shows a
/// whole frame and two screenshots half a second apart show the same view.
pub(super) fn view_steady(harness: &mut Harness, value: &str) -> Result<(), String> {
    let seconds: f64 =
        value.trim_end_matches('s').parse().map_err(|_| format!("view-steady wants seconds, not '{value}'"))?;
    let started = Instant::now();
    let mut before = harness.screenshot();
    while started.elapsed().as_secs_f64() < seconds {
        for _ in 0..25 {
            std::thread::sleep(Duration::from_millis(20));
            harness.wait(Duration::from_millis(20));
        }
        let now = harness.screenshot();
        if harness.app().view_whole() && view_pixels(harness, &now)? == view_pixels(harness, &before)? {
            return Ok(());
        }
        before = now;
    }
    Err(format!("the 3-D view still changes after {seconds} s"))
}

/// `expect same-result NAME` (module doc).
pub(super) fn same_result(
    harness: &mut Harness,
    taken: &HashMap<String, RgbImage>,
    results: &HashMap<String, String>,
    value: &str,
) -> Result<(), String> {
    let (earlier, then) =
        taken.get(value).zip(results.get(value)).ok_or(format!("no screenshot named '{value}' was taken"))?;
    let now = harness.app().result_digest();
    if now != *then {
        return Err(format!("the result is '{now}', at '{value}' it was '{then}'"));
    }
    let screen = harness.screenshot();
    let difference = mean_difference(&view_pixels(harness, &screen)?, &view_pixels(harness, earlier)?);
    if difference < 0.05 {
        Ok(())
    } else {
        Err(format!("the 3-D view differs from '{value}' (mean difference {difference:.3} levels)"))
    }
}

/// `expect letters "slice z" A,L,P,R` (module doc).
fn expect_letters(harness: &Harness, value: &str) -> Result<(), String> {
    let usage = || format!("letters wants ELEMENT TOP,RIGHT,BOTTOM,LEFT, not '{value}'");
    let (element, letters) = value.rsplit_once(' ').ok_or_else(usage)?;
    let wanted: Vec<&str> = letters.split(',').collect();
    if wanted.len() != 4 {
        return Err(usage());
    }
    let picture = harness.element_rect(element).ok_or(format!("no element '{element}' on screen"))?;
    // The picture may be zoomed beyond its area: the letters sit on the part that shows.
    let area = element
        .strip_prefix("slice ")
        .and_then(|axis| harness.element_rect(&format!("slice area {axis}")))
        .unwrap_or(picture);
    let left = picture.x.max(area.x);
    let top = picture.y.max(area.y);
    let shown = Rect {
        x: left,
        y: top,
        width: (picture.x + picture.width).min(area.x + area.width) - left,
        height: (picture.y + picture.height).min(area.y + area.height) - top,
    };
    let mut problems = Vec::new();
    for (edge, want) in ["top", "right", "bottom", "left"].into_iter().zip(wanted) {
        let label = format!("{element} letter {edge}");
        let Some((rect, letter)) = harness.element_value(&label) else {
            problems.push(format!("no {edge} letter"));
            continue;
        };
        if letter != want {
            problems.push(format!("{edge} is '{letter}', expected '{want}'"));
        }
        let centre = rect.point([0.5, 0.5]);
        let at_edge = shown.contains(centre)
            && match edge {
                "top" => centre[1] < shown.y + 0.25 * shown.height,
                "bottom" => centre[1] > shown.y + 0.75 * shown.height,
                "left" => centre[0] < shown.x + 0.25 * shown.width,
                _ => centre[0] > shown.x + 0.75 * shown.width,
            };
        if !at_edge {
            problems.push(format!("the {edge} letter is at {centre:?}, not at that edge of {shown:?}"));
        }
    }
    if problems.is_empty() { Ok(()) } else { Err(format!("{element}: {}", problems.join("; "))) }
}

/// The RGB pixels of the 3-D view's rectangle in `screen`.
fn view_pixels(harness: &Harness, screen: &RgbImage) -> Result<Vec<[u8; 3]>, String> {
    let rect = harness.element_rect("view").ok_or("the 3-D view is not on screen")?;
    let (x0, y0) = (rect.x.max(0.0) as usize, rect.y.max(0.0) as usize);
    let (x1, y1) =
        (((rect.x + rect.width) as usize).min(screen.width), ((rect.y + rect.height) as usize).min(screen.height));
    let mut pixels = Vec::with_capacity((x1.saturating_sub(x0)) * (y1.saturating_sub(y0)));
    for y in y0..y1 {
        for x in x0..x1 {
            let p = &screen.pixels[3 * (y * screen.width + x)..][..3];
            pixels.push([p[0], p[1], p[2]]);
        }
    }
    Ok(pixels)
}

/// Hues (12 bins of 30 degrees) held by at least 0.2 % of the pixels that are coloured
/// (saturation and value above a quarter): how many classes the view visibly shows.
pub fn distinct_hues(pixels: &[[u8; 3]]) -> usize {
    let mut bins = [0usize; 12];
    for &[r, g, b] in pixels {
        let (max, min) = (r.max(g).max(b) as f32, r.min(g).min(b) as f32);
        if max < 64.0 || (max - min) / max < 0.25 {
            continue;
        }
        let (r, g, b) = (r as f32, g as f32, b as f32);
        let hue = if max == r {
            60.0 * ((g - b) / (max - min)).rem_euclid(6.0)
        } else if max == g {
            60.0 * ((b - r) / (max - min) + 2.0)
        } else {
            60.0 * ((r - g) / (max - min) + 4.0)
        };
        bins[((hue / 30.0) as usize).min(11)] += 1;
    }
    let threshold = (pixels.len() / 500).max(1);
    bins.iter().filter(|&&count| count >= threshold).count()
}

/// A pixel changed when one of its channels moved by more than this many levels.
const CHANGED_LEVELS: u8 = 16;

/// The share of the 3-D view's pixels that must change for `view-differs` when the mean
/// difference is under a level: a frame's rendering noise changes none by that much.
const MIN_CHANGED_SHARE: f64 = 0.01;

/// The share of pixels of which a channel differs by more than [`CHANGED_LEVELS`] (1 when the
/// sizes differ).
fn changed_share(a: &[[u8; 3]], b: &[[u8; 3]]) -> f64 {
    if a.len() != b.len() || a.is_empty() {
        return 1.0;
    }
    let changed = a.iter().zip(b).filter(|(p, q)| (0..3).any(|c| p[c].abs_diff(q[c]) > CHANGED_LEVELS)).count();
    changed as f64 / a.len() as f64
}

fn mean_difference(a: &[[u8; 3]], b: &[[u8; 3]]) -> f64 {
    if a.len() != b.len() || a.is_empty() {
        return f64::INFINITY;
    }
    let total: u64 =
        a.iter().zip(b).flat_map(|(p, q)| (0..3).map(move |c| (p[c] as i32 - q[c] as i32).unsigned_abs() as u64)).sum();
    total as f64 / (3 * a.len()) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distinct_hues_counts_coloured_regions_and_ignores_grey() {
        let mut pixels = vec![[128u8, 128, 128]; 1000];
        pixels.extend(vec![[220u8, 30, 30]; 100]);
        assert_eq!(distinct_hues(&pixels), 1);
        pixels.extend(vec![[30u8, 200, 220]; 100]);
        assert_eq!(distinct_hues(&pixels), 2);
        pixels.extend(vec![[10u8, 10, 60]; 500]);
        assert_eq!(distinct_hues(&pixels), 2, "dark pixels are not a colour");
    }

    #[test]
    fn a_small_structure_that_changes_counts_as_a_changed_view() {
        let before = vec![[0u8, 0, 0]; 10_000];
        let mut after = before.clone();
        for pixel in &mut after[..200] {
            *pixel = [20, 40, 45];
        }
        assert!(mean_difference(&before, &after) < 1.0, "diluted by the black around it");
        assert!(changed_share(&before, &after) >= MIN_CHANGED_SHARE);
        let mut noise = before.clone();
        for pixel in noise.iter_mut().step_by(3) {
            *pixel = [3, 2, 4];
        }
        assert_eq!(changed_share(&before, &noise), 0.0, "small level changes are not a change");
    }
}
