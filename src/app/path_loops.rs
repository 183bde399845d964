//! The closed loops within a finger path: where it crosses itself, and where it comes back
//! near one of its own points.
//!
//! A finger seldom ends exactly where it began: it runs on past its start to be sure the loop
//! is shut, goes round twice, drifting in or out, or lands inside the structure and sweeps out
//! to its edge before circling it. Taken whole as one polygon under the strokes contract's
//! even-odd rule, the part circled twice would be left out of the lasso (a hole where the finger
//! was most insistent), and a path that ran half a turn past its start would not count as
//! closed at all. So the loops inside the path are offered as well:
//! * at each crossing of two segments, the loop between them, and for a path that came back
//!   near its start (closed by the edge back to it) also the loop the other way round;
//! * each prefix that ends where the path comes back near its start (a spiral, or a run past
//!   the start that does not cross it), and each suffix that starts where the path's end comes
//!   back to (a tail before the loop).
//!
//! The caller ([`super::drawing`]) weighs them with the whole path.
//!
//! Never: decides what a path means, or knows about slices and voxels.

/// A path that crosses itself more often than this is a scribble (or a touch storm): it
/// encloses nothing a user meant, and no loop within it is offered.
pub const MAX_CROSSINGS: usize = 16;

/// At most this many prefixes, and as many suffixes, are offered (the closest returns first).
pub const MAX_RETURNS: usize = 8;

/// Every loop within the path (module doc): those its crossings close, and the prefixes and
/// suffixes that end where the path comes back within `close_fraction` of their extent (the
/// larger side of their bounding box) of their first point. The whole path is not among them;
/// a scribble (more than [`MAX_CROSSINGS`] crossings) has none.
pub fn loops_within(points: &[[f32; 2]], closed: bool, close_fraction: f32) -> Vec<Vec<[f32; 2]>> {
    let Some(mut loops) = crossing_loops(points, closed) else {
        return Vec::new();
    };
    for end in returns_to_start(points, close_fraction) {
        loops.push(points[..=end].to_vec());
    }
    let reversed: Vec<[f32; 2]> = points.iter().rev().copied().collect();
    for end in returns_to_start(&reversed, close_fraction) {
        loops.push(reversed[..=end].to_vec());
    }
    loops
}

/// The indices `j` (neither the first two nor the last) where the path comes back to its first
/// point: the distance to it is a local minimum and at most `close_fraction` of the extent of
/// `points[..=j]`; the closest (relative to that extent) first, at most [`MAX_RETURNS`].
fn returns_to_start(points: &[[f32; 2]], close_fraction: f32) -> Vec<usize> {
    let n = points.len();
    if n < 4 {
        return Vec::new();
    }
    let first = points[0];
    let distance = |p: [f32; 2]| (p[0] - first[0]).hypot(p[1] - first[1]);
    let (mut low, mut high) = (first, first);
    let mut returns: Vec<(f32, usize)> = Vec::new();
    for j in 1..n - 1 {
        for a in 0..2 {
            low[a] = low[a].min(points[j][a]);
            high[a] = high[a].max(points[j][a]);
        }
        let extent = (high[0] - low[0]).max(high[1] - low[1]);
        let here = distance(points[j]);
        let minimum = here <= distance(points[j - 1]) && here <= distance(points[j + 1]);
        if j >= 2 && minimum && extent > 0.0 && here <= close_fraction * extent {
            returns.push((here / extent, j));
        }
    }
    returns.sort_by(|a, b| a.0.total_cmp(&b.0));
    returns.into_iter().take(MAX_RETURNS).map(|(_, j)| j).collect()
}

/// The loops closed where the path's segments cross. For segments `k < m` (not neighbours)
/// crossing at X, the loop X, `points[k+1..=m]`. When `closed`, the edge from the last point
/// back to the first is a segment too, and each crossing also closes the loop that goes the
/// other way round: X, `points[m+1..]`, `points[..=k]`. None for a scribble (more than
/// [`MAX_CROSSINGS`] crossings).
pub fn crossing_loops(points: &[[f32; 2]], closed: bool) -> Option<Vec<Vec<[f32; 2]>>> {
    let n = points.len();
    let segments = if closed { n } else { n.saturating_sub(1) };
    if n < 3 || segments < 3 {
        return Some(Vec::new());
    }
    let end = |s: usize| (points[s], points[(s + 1) % n]);
    let boxes: Vec<[f32; 4]> = (0..segments)
        .map(|s| {
            let (a, b) = end(s);
            [a[0].min(b[0]), a[1].min(b[1]), a[0].max(b[0]), a[1].max(b[1])]
        })
        .collect();
    let mut loops = Vec::new();
    let mut crossings = 0;
    for k in 0..segments {
        for m in k + 2..segments {
            if closed && k == 0 && m == segments - 1 {
                continue; // the closing edge and the first segment share the first point
            }
            let (p, q) = (boxes[k], boxes[m]);
            if p[0] > q[2] || q[0] > p[2] || p[1] > q[3] || q[1] > p[3] {
                continue;
            }
            let Some(crossing) = crossing_point(end(k), end(m)) else { continue };
            let mut inner = vec![crossing];
            inner.extend_from_slice(&points[k + 1..=m]);
            loops.push(inner);
            if closed {
                let mut outer = vec![crossing];
                outer.extend_from_slice(&points[m + 1..]);
                outer.extend_from_slice(&points[..=k]);
                loops.push(outer);
            }
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                return None;
            }
        }
    }
    Some(loops)
}

/// Where segment `a` crosses segment `b`, if it does (parallel segments never do here).
fn crossing_point(a: ([f32; 2], [f32; 2]), b: ([f32; 2], [f32; 2])) -> Option<[f32; 2]> {
    let wide = |p: [f32; 2]| [p[0] as f64, p[1] as f64];
    let (p, p2, q, q2) = (wide(a.0), wide(a.1), wide(b.0), wide(b.1));
    let r = [p2[0] - p[0], p2[1] - p[1]];
    let s = [q2[0] - q[0], q2[1] - q[1]];
    let cross = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
    let denominator = cross(r, s);
    if denominator == 0.0 {
        return None;
    }
    let qp = [q[0] - p[0], q[1] - p[1]];
    let t = cross(qp, s) / denominator;
    let u = cross(qp, r) / denominator;
    ((0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u)).then(|| [(p[0] + t * r[0]) as f32, (p[1] + t * r[1]) as f32])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn circle(turns: f32, points_per_turn: usize, radius: f32) -> Vec<[f32; 2]> {
        let count = (turns * points_per_turn as f32) as usize;
        (0..=count)
            .map(|k| {
                let angle = k as f32 / points_per_turn as f32 * std::f32::consts::TAU;
                [100.0 + radius * angle.cos(), 100.0 + radius * angle.sin()]
            })
            .collect()
    }

    #[test]
    fn a_simple_loop_has_no_crossing() {
        assert_eq!(crossing_loops(&circle(0.95, 64, 50.0), true), Some(Vec::new()));
        assert_eq!(crossing_loops(&circle(0.95, 64, 50.0), false), Some(Vec::new()));
    }

    #[test]
    fn a_loop_run_past_its_start_splits_into_the_full_turn_and_the_overshoot() {
        // A circle of radius 50 whose first quarter starts at 45 and widens to 55, run a
        // quarter turn past its start: the overshoot crosses the first quarter once.
        let mut path = circle(1.25, 64, 50.0);
        for (k, point) in path.iter_mut().enumerate() {
            // The overshoot a little wider, so it crosses between points, not on one.
            let radius = if k <= 16 {
                45.0 + 10.0 * k as f32 / 16.0
            } else if k > 64 {
                50.5
            } else {
                50.0
            };
            *point = [100.0 + (point[0] - 100.0) * radius / 50.0, 100.0 + (point[1] - 100.0) * radius / 50.0];
        }
        let loops = crossing_loops(&path, false).expect("one crossing");
        assert_eq!(loops.len(), 1, "{loops:?}");
        // The full turn: 64 points and the crossing.
        assert!((64..=66).contains(&loops[0].len()), "{}", loops[0].len());
        // Closed, the overshoot with the closing edge is the other loop.
        let closed = crossing_loops(&path, true).expect("one crossing");
        assert!(closed.iter().any(|l| l.len() > 60) && closed.iter().any(|l| l.len() < 25), "{closed:?}");
    }

    #[test]
    fn a_spiral_never_crosses_itself_but_returns_near_its_start_after_each_turn() {
        let spiral: Vec<[f32; 2]> = circle(2.0, 64, 50.0)
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let scale = 1.0 - 0.1 * k as f32 / 64.0;
                [100.0 + (p[0] - 100.0) * scale, 100.0 + (p[1] - 100.0) * scale]
            })
            .collect();
        assert_eq!(crossing_loops(&spiral, false), Some(Vec::new()));
        let loops = loops_within(&spiral, false, 0.35);
        // The first turn as a prefix (65 points), and the last turn as a suffix.
        assert!(
            loops.iter().any(|l| l.len() == 65 && l[0] == spiral[0]),
            "{:?}",
            loops.iter().map(Vec::len).collect::<Vec<_>>()
        );
        assert!(loops.iter().any(|l| l.len() == 65 && l[0] == spiral[128]));
    }

    #[test]
    fn a_tail_before_the_loop_is_left_off_by_a_suffix() {
        // From the centre out to the rim, then round, ending just short of where the tail met it.
        let mut path: Vec<[f32; 2]> = (0..10).map(|k| [100.0 + 5.0 * k as f32, 100.0]).collect();
        path.extend(circle(0.97, 64, 50.0));
        let loops = loops_within(&path, false, 0.35);
        assert!(loops.iter().any(|l| l[0] == path[path.len() - 1] && (60..=64).contains(&l.len())), "{loops:?}");
    }

    #[test]
    fn a_figure_eight_splits_at_its_waist_into_its_lobes() {
        let eight: Vec<[f32; 2]> = (0..=64)
            .map(|k| {
                let t = k as f32 / 64.0 * std::f32::consts::TAU;
                [100.0 + 60.0 * t.sin(), 100.0 + 30.0 * (2.0 * t).sin()]
            })
            .collect();
        let loops = crossing_loops(&eight, true).expect("one crossing");
        assert!(!loops.is_empty());
        for lobe in &loops {
            let xs: Vec<f32> = lobe.iter().map(|p| p[0]).collect();
            let (low, high) = xs.iter().fold((f32::MAX, f32::MIN), |(l, h), &x| (l.min(x), h.max(x)));
            assert!(low >= 99.0 || high <= 101.0, "a lobe crosses the waist: {low}..{high}");
        }
    }

    #[test]
    fn a_scribble_offers_no_loop() {
        // Chords of a circle, each 2.3 radians on from the last: a star crossing itself everywhere.
        let scribble: Vec<[f32; 2]> = (0..4096)
            .map(|k| {
                let angle = k as f32 * 2.3;
                [100.0 + 50.0 * angle.cos(), 100.0 + 50.0 * angle.sin()]
            })
            .collect();
        assert_eq!(crossing_loops(&scribble, false), None);
        assert!(loops_within(&scribble, true, 0.35).is_empty());
        assert_eq!(crossing_loops(&scribble[..2], true), Some(Vec::new()));
    }
}
