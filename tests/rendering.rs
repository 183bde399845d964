//! What `volasso render` draws with the default class table: every class can be seen.

use crate::support::{data, volasso};
use volasso::transfer::HueTemplate;

/// Shares (in %) of the coloured pixels of `image` whose hue is nearest each class's hue
/// range (the default template for `classes`). Coloured: HSV value >= 40/255 and saturation
/// >= 0.25 (the black background and grey blends count for no class).
fn hue_shares(image: &image::RgbaImage, classes: usize) -> Vec<f64> {
    let centres: Vec<f32> =
        HueTemplate::default_for(classes).hue_ranges(classes).iter().map(|[low, high]| (low + high) / 2.0).collect();
    let mut counts = vec![0usize; classes];
    for pixel in image.pixels() {
        let [r, g, b] = [0, 1, 2].map(|c| pixel.0[c] as f32 / 255.0);
        let (max, min) = (r.max(g).max(b), r.min(g).min(b));
        let chroma = max - min;
        if max < 40.0 / 255.0 || chroma < 0.25 * max {
            continue;
        }
        let sector = if max == r {
            ((g - b) / chroma).rem_euclid(6.0)
        } else if max == g {
            (b - r) / chroma + 2.0
        } else {
            (r - g) / chroma + 4.0
        };
        let hue = sector * 60.0;
        let distance = |centre: f32| {
            let d = (hue - centre).rem_euclid(360.0);
            d.min(360.0 - d)
        };
        let nearest = (0..classes).min_by(|&a, &b| distance(centres[a]).total_cmp(&distance(centres[b])));
        counts[nearest.unwrap_or(0)] += 1;
    }
    let total = counts.iter().sum::<usize>().max(1) as f64;
    counts.iter().map(|&c| 100.0 * c as f64 / total).collect()
}

fn render(volume: &str, strokes: &str, out: &std::path::Path, cache: &std::path::Path) -> image::RgbaImage {
    let strokes = format!("{}/benches/strokes/{strokes}", env!("CARGO_MANIFEST_DIR"));
    let output = volasso(&["render", volume, "--strokes", &strokes, "--out", out.to_str().unwrap()], cache);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    image::open(out).unwrap().to_rgba8()
}

#[test]
fn the_engine_and_the_demo_foot_show_every_class_in_the_default_view() {
    let folder = tempfile::tempdir().unwrap();
    let engine = data("engine_256x256x256_uint8.raw");
    let cases = [(engine.to_str().unwrap(), "engine.strokes.json"), ("demo", "demo-foot.strokes.json")];
    for (volume, strokes) in cases {
        let image = render(volume, strokes, &folder.path().join("view.png"), folder.path());
        let shares = hue_shares(&image, 2);
        eprintln!("{strokes}: hue shares {shares:?} %");
        assert!(shares.iter().all(|&share| share >= 10.0), "{strokes}: a class covers under 10 %: {shares:?}");
    }
}
