//! Lassos a careful user would draw on the demo foot: the strokes of the demo session and the
//! training input of classification tests.

use super::Phantom;
use crate::slices::{Axis, SliceGeometry, slice_entropies};
use crate::strokes::{ClassStrokes, Lasso, StrokesFile};
use std::collections::VecDeque;

/// On the top-entropy slice of each axis, for each class id in `classes`, up to `per_slice`
/// octagons of `radius_pixels` around the points deepest inside that class (never reaching
/// another class), at least 4 radii apart. Class k of the file is `classes[k - 1]`, named
/// after the phantom's class. A class with no room for a lasso gets no strokes.
pub fn lassos_inside(phantom: &Phantom, classes: &[u8], per_slice: usize, radius_pixels: f64) -> StrokesFile {
    let entropies = slice_entropies(&phantom.volume);
    let dims = phantom.volume.dims;
    let mut file = StrokesFile {
        classes: classes
            .iter()
            .map(|&class| ClassStrokes { name: phantom.class_names[class as usize].to_string(), strokes: Vec::new() })
            .collect(),
    };
    // City-block depth that keeps the whole octagon inside the class.
    let needed_depth = (radius_pixels * std::f64::consts::SQRT_2).ceil() as u32 + 1;
    for axis in Axis::ALL {
        let slice = entropies.axis(axis).top();
        let Some(geometry) = SliceGeometry::new(dims, axis, slice) else {
            continue;
        };
        let class_at = |i: usize, j: usize| phantom.truth[geometry.voxel_index(i, j)];
        let depth = depth_inside_class(&geometry, class_at);
        for (position, &class) in classes.iter().enumerate() {
            let mut candidates: Vec<(u32, usize, usize)> = (0..geometry.height)
                .flat_map(|j| (0..geometry.width).map(move |i| (i, j)))
                .filter(|&(i, j)| class_at(i, j) == class)
                .map(|(i, j)| (depth[j * geometry.width + i], i, j))
                .filter(|&(d, _, _)| d >= needed_depth)
                .collect();
            // Shallowest first: lassos hug the inside of the outline, as a user tracing a
            // structure does, so training sees its edges as well as its core.
            candidates.sort_by(|a, b| a.0.cmp(&b.0).then((a.2, a.1).cmp(&(b.2, b.1))));
            let mut centres: Vec<(f64, f64)> = Vec::new();
            for (_, i, j) in candidates {
                let (x, y) = (i as f64, j as f64);
                let spread = 4.0 * radius_pixels;
                if centres.iter().all(|&(a, b)| (a - x).hypot(b - y) >= spread) {
                    centres.push((x, y));
                    if centres.len() == per_slice {
                        break;
                    }
                }
            }
            for (x, y) in centres {
                let points = (0..8)
                    .map(|k| {
                        let angle = std::f64::consts::FRAC_PI_4 * (k as f64 + 0.5);
                        [x + radius_pixels * angle.cos(), y + radius_pixels * angle.sin()]
                    })
                    .collect();
                file.classes[position].strokes.push(Lasso { axis, slice, points });
            }
        }
    }
    file
}

/// City-block distance (in pixels) of every pixel of a slice to the nearest pixel of another
/// class or beyond the image border; 1 on a class boundary.
pub(crate) fn depth_inside_class(geometry: &SliceGeometry, class_at: impl Fn(usize, usize) -> u8) -> Vec<u32> {
    let (width, height) = (geometry.width, geometry.height);
    let mut depth = vec![u32::MAX; width * height];
    let mut queue = VecDeque::new();
    for j in 0..height {
        for i in 0..width {
            let class = class_at(i, j);
            let on_edge = i == 0 || j == 0 || i + 1 == width || j + 1 == height;
            let boundary = on_edge
                || class_at(i - 1, j) != class
                || class_at(i + 1, j) != class
                || class_at(i, j - 1) != class
                || class_at(i, j + 1) != class;
            if boundary {
                depth[j * width + i] = 1;
                queue.push_back((i, j));
            }
        }
    }
    while let Some((i, j)) = queue.pop_front() {
        let next = depth[j * width + i] + 1;
        let class = class_at(i, j);
        let neighbours = [(i.wrapping_sub(1), j), (i + 1, j), (i, j.wrapping_sub(1)), (i, j + 1)];
        for (a, b) in neighbours {
            if a < width && b < height && class_at(a, b) == class && depth[b * width + a] > next {
                depth[b * width + a] = next;
                queue.push_back((a, b));
            }
        }
    }
    depth
}
