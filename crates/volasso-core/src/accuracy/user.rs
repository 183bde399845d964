//! The simulated user: lassos drawn from a ground-truth label volume on the top-entropy
//! slices, the way a person draws them on the touchscreen.
//!
//! For each class and each of its lassos: pick one of the top-entropy slices (axes in turn),
//! find the class's pixels there eroded by `erosion_pixels` (a user stays inside the outline;
//! a class too thin for that uses its deepest pixels), pick a random centre among them, and
//! grow a closed finger-shaped outline (a circle whose radius wobbles with the angle) until it
//! encloses the class's share of the voxel budget. Where the eroded pixels cannot supply that
//! share (a thin ribbon erodes to a broken ridge), the user erodes less, down to the class's
//! own pixels, as a person tracing a thin structure does. The lasso keeps the pixels inside the
//! outline that are connected to the centre within the allowed pixels. A sloppy user's allowed
//! pixels reach `sloppy_pixels` beyond the class's true border instead (lassos that cross it).
//! Voxels claimed by two classes are dropped from both, as `TrainingSet` does.
//!
//! Never: looks at intensities (only at the truth and the slice ranking).

use crate::phantom::Phantom;
use crate::rng::SplitMix64;
use crate::slices::{Axis, SliceGeometry, slice_entropies};
use crate::strokes::{ClassSamples, TrainingSet};
use std::collections::{HashMap, VecDeque};

/// How the simulated user draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UserModel {
    /// Lassos drawn for each class (on the most informative slices, axes in turn).
    pub lassos_per_class: usize,
    /// Voxels per class the lassos aim for together.
    pub voxel_budget_per_class: usize,
    /// Pixels a careful lasso stays inside the class's outline.
    pub erosion_pixels: u32,
    /// When non-zero, lassos may reach this many pixels beyond the class's border.
    pub sloppy_pixels: u32,
    /// Top-entropy slices per axis to draw on.
    pub slices_per_axis: usize,
    /// Whether truth class 0 (the air or background around the body) is lassoed as a class.
    pub lasso_background: bool,
}

impl Default for UserModel {
    fn default() -> Self {
        UserModel {
            lassos_per_class: 2,
            voxel_budget_per_class: 130,
            erosion_pixels: 2,
            sloppy_pixels: 0,
            slices_per_axis: 1,
            lasso_background: true,
        }
    }
}

/// The training set the simulated user draws on `phantom`: class id k + 1 = truth class k, or
/// with the background left alone, class id k = truth class k >= 1.
pub fn draw_training(phantom: &Phantom, user: &UserModel, seed: u64) -> TrainingSet {
    let entropies = slice_entropies(&phantom.volume);
    let dims = phantom.volume.dims;
    let mut slices: Vec<SliceGeometry> = Vec::new();
    for rank in 0..user.slices_per_axis.max(1) {
        for axis in Axis::ALL {
            if let Some(&slice) = entropies.axis(axis).top_slices(rank + 1).get(rank)
                && let Some(geometry) = SliceGeometry::new(dims, axis, slice)
            {
                slices.push(geometry);
            }
        }
    }
    let mut rng = SplitMix64::new(seed);
    let class_count = phantom.class_names.len();
    let first_class = u8::from(!user.lasso_background);
    let mut owner: HashMap<usize, (u8, u32)> = HashMap::new();
    let mut contested: Vec<usize> = Vec::new();
    let per_lasso = user.voxel_budget_per_class.div_ceil(user.lassos_per_class.max(1));
    for class in first_class..class_count as u8 {
        for lasso in 0..user.lassos_per_class {
            // Axes in turn, starting somewhere random, skipping slices without the class; a
            // class on none of them is looked for on the z slice that shows most of it.
            let start = rng.below(slices.len() as u64) as usize;
            let fallback = SliceGeometry::new(dims, Axis::Z, slice_showing_most(phantom, class));
            let candidates: Vec<&SliceGeometry> = (0..slices.len())
                .map(|attempt| &slices[(start + lasso + attempt) % slices.len()])
                .chain(fallback.as_ref())
                .collect();
            for geometry in candidates {
                let voxels = draw_lasso(phantom, geometry, class, per_lasso, user, &mut rng);
                if voxels.is_empty() {
                    continue;
                }
                for voxel in voxels {
                    match owner.get(&voxel) {
                        Some(&(other, _)) if other != class => contested.push(voxel),
                        Some(_) => {}
                        None => {
                            owner.insert(voxel, (class, lasso as u32));
                        }
                    }
                }
                break;
            }
        }
    }
    for voxel in &contested {
        owner.remove(voxel);
    }
    contested.sort_unstable();
    contested.dedup();
    let mut classes: Vec<ClassSamples> = phantom.class_names[first_class as usize..]
        .iter()
        .map(|name| ClassSamples {
            name: name.to_string(),
            voxels: Vec::new(),
            stroke_of_voxel: Vec::new(),
            stroke_voxel_counts: vec![0; user.lassos_per_class],
            dropped_by_cap: 0,
        })
        .collect();
    let mut owned: Vec<(usize, u8, u32)> =
        owner.into_iter().map(|(voxel, (class, lasso))| (voxel, class, lasso)).collect();
    owned.sort_unstable();
    for (voxel, class, lasso) in owned {
        let samples = &mut classes[(class - first_class) as usize];
        samples.voxels.push(voxel);
        samples.stroke_of_voxel.push(lasso);
        samples.stroke_voxel_counts[lasso as usize] += 1;
    }
    TrainingSet { classes, contested_voxels: contested.len() }
}

/// The z slice with the most voxels of `class`.
fn slice_showing_most(phantom: &Phantom, class: u8) -> usize {
    let plane = phantom.volume.dims[0] * phantom.volume.dims[1];
    let counts = phantom.truth.chunks(plane).map(|slice| slice.iter().filter(|&&c| c == class).count());
    counts.enumerate().max_by_key(|&(z, count)| (count, std::cmp::Reverse(z))).map_or(0, |(z, _)| z)
}

/// One lasso of `class` on the slice `geometry`: volume indices, empty when the class is not
/// on the slice.
fn draw_lasso(
    phantom: &Phantom,
    geometry: &SliceGeometry,
    class: u8,
    target_voxels: usize,
    user: &UserModel,
    rng: &mut SplitMix64,
) -> Vec<usize> {
    let (width, height) = (geometry.width, geometry.height);
    let class_at = |i: usize, j: usize| phantom.truth[geometry.voxel_index(i, j)];
    let depth = crate::phantom::lassos::depth_inside_class(geometry, class_at);
    let inside: Vec<usize> = (0..width * height).filter(|&k| class_at(k % width, k / width) == class).collect();
    if inside.is_empty() {
        return Vec::new();
    }
    let deepest = inside.iter().map(|&k| depth[k]).max().unwrap_or(1);
    let needed_depth = (user.erosion_pixels + 1).min(deepest);
    let centres: Vec<usize> = inside.iter().copied().filter(|&k| depth[k] >= needed_depth).collect();
    let centre = centres[rng.below(centres.len() as u64) as usize];
    // The finger's wobble: two harmonics with random phases.
    let (phase_a, phase_b) = (rng.next_f64() * std::f64::consts::TAU, rng.next_f64() * std::f64::consts::TAU);
    // A careful user stays `erosion_pixels` inside the outline where the structure is wide
    // enough; on a thin one (a cortex ribbon, a skin layer) that leaves a broken ridge of a few
    // pixels, so the user keeps closer to the border, down to the structure itself, until the
    // lasso holds its share of the budget.
    let mut best: Vec<usize> = Vec::new();
    for min_depth in (1..=needed_depth).rev() {
        let allowed: Vec<bool> = if user.sloppy_pixels > 0 {
            dilate(&inside, width, height, user.sloppy_pixels)
        } else {
            let mut allowed = vec![false; width * height];
            for &k in &inside {
                allowed[k] = depth[k] >= min_depth;
            }
            allowed
        };
        let region = grow_outline(centre, width, height, &allowed, target_voxels, (phase_a, phase_b));
        if region.len() > best.len() {
            best = region;
        }
        if best.len() >= target_voxels || user.sloppy_pixels > 0 {
            break;
        }
    }
    best.into_iter().map(|k| geometry.voxel_index(k % width, k / width)).collect()
}

/// The pixels of `allowed` connected to `centre` inside a finger-drawn outline around it, the
/// outline grown until it holds `target_voxels` of them (or reaches 60 pixels).
fn grow_outline(
    centre: usize,
    width: usize,
    height: usize,
    allowed: &[bool],
    target_voxels: usize,
    (phase_a, phase_b): (f64, f64),
) -> Vec<usize> {
    let (centre_i, centre_j) = ((centre % width) as f64, (centre / width) as f64);
    let mut radius = 1.5;
    loop {
        let outline = |i: usize, j: usize| {
            let (di, dj) = (i as f64 - centre_i, j as f64 - centre_j);
            let angle = dj.atan2(di);
            let reach = radius * (1.0 + 0.22 * (3.0 * angle + phase_a).sin() + 0.1 * (7.0 * angle + phase_b).sin());
            di.hypot(dj) <= reach
        };
        let region = connected_within(centre, width, height, |k| allowed[k] && outline(k % width, k / width));
        if region.len() >= target_voxels || radius > 60.0 {
            return region;
        }
        radius *= 1.15;
    }
}

/// Pixels connected (4-neighbours) to `start` among those where `keep` holds.
fn connected_within(start: usize, width: usize, height: usize, keep: impl Fn(usize) -> bool) -> Vec<usize> {
    let mut seen = vec![false; width * height];
    let mut region = Vec::new();
    let mut queue = VecDeque::from([start]);
    seen[start] = true;
    while let Some(k) = queue.pop_front() {
        region.push(k);
        let (i, j) = (k % width, k / width);
        let neighbours = [(i.wrapping_sub(1), j), (i + 1, j), (i, j.wrapping_sub(1)), (i, j + 1)];
        for (a, b) in neighbours {
            if a < width && b < height && !seen[b * width + a] && keep(b * width + a) {
                seen[b * width + a] = true;
                queue.push_back(b * width + a);
            }
        }
    }
    region
}

/// The pixels within `reach` city-block steps of `pixels`.
fn dilate(pixels: &[usize], width: usize, height: usize, reach: u32) -> Vec<bool> {
    let mut distance = vec![u32::MAX; width * height];
    let mut queue: VecDeque<usize> = pixels.iter().copied().collect();
    for &k in pixels {
        distance[k] = 0;
    }
    while let Some(k) = queue.pop_front() {
        if distance[k] >= reach {
            continue;
        }
        let (i, j) = (k % width, k / width);
        for (a, b) in [(i.wrapping_sub(1), j), (i + 1, j), (i, j.wrapping_sub(1)), (i, j + 1)] {
            if a < width && b < height && distance[b * width + a] == u32::MAX {
                distance[b * width + a] = distance[k] + 1;
                queue.push_back(b * width + a);
            }
        }
    }
    distance.into_iter().map(|d| d <= reach).collect()
}
