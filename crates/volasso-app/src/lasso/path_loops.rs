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
//! A tremor's curls (loops smaller than the caller's least loop, closed within a short stretch
//! of path) close nothing, and a finger running along its own path, crossing it at every wobble,
//! closes one loop there, not one per crossing. [`uncurled`] cuts the curls out of a path (under
//! the even-odd rule each would be a hole in a lasso); [`steadied`] averages jitter out of it
//! before its loops are looked for, and a [`PathLoop`] found on the steadied path is drawn
//! through the points the finger gave.
//!
//! The caller ([`crate::lasso::drawing`]) weighs them with the whole path.
//!
//! Never: decides what a path means, or knows about slices and voxels.

/// A path that crosses itself more often than this is a scribble (or a touch storm): it
/// encloses nothing a user meant, and no loop within it is offered.
pub const MAX_CROSSINGS: usize = 16;

/// A loop closed by a crossing whose path is at most this long (in the caller's units, screen
/// pixels) and which encloses less than the caller's least loop area is a curl: a fingertip's
/// tremor or a jittery panel's zigzag, not a loop anyone drew. Curls are neither offered nor
/// counted as crossings, so a loop drawn with a shaking finger is not taken for a scribble.
pub const CURL_MAX_LENGTH: f32 = 64.0;

/// At most this many prefixes, and as many suffixes, are offered (the closest returns first).
pub const MAX_RETURNS: usize = 8;

/// At most this many points on either side of a point are averaged with it ([`steadied`]).
const STEADY_MAX_SIDE: usize = 24;

/// Each point of `points` replaced by the mean of the run of points around it that stay within
/// `reach` of it (at most [`STEADY_MAX_SIDE`] on either side): a fingertip's tremor and a
/// panel's jitter, a few pixels to and fro between reports, averaged out before the path is
/// read, while anything larger than `reach` (a loop's corners, a tail) keeps its shape. The
/// run is measured by distance, not along the path, whose length jitter inflates. The first
/// and last points stay where they are, so a path's gap from end to start is the one drawn.
pub fn steadied(points: &[[f32; 2]], reach: f32) -> Vec<[f32; 2]> {
    let n = points.len();
    let within = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) <= reach;
    (0..n)
        .map(|k| {
            if k == 0 || k + 1 == n {
                return points[k];
            }
            let here = points[k];
            let mut low = k;
            while low > 0 && k - low < STEADY_MAX_SIDE && within(points[low - 1], here) {
                low -= 1;
            }
            let mut high = k;
            while high + 1 < n && high - k < STEADY_MAX_SIDE && within(points[high + 1], here) {
                high += 1;
            }
            // About the point itself, so paths far from the origin keep their precision.
            let run = &points[low..=high];
            let sum = run.iter().fold([0.0f32; 2], |sum, p| [sum[0] + p[0] - here[0], sum[1] + p[1] - here[1]]);
            let count = run.len() as f32;
            [here[0] + sum[0] / count, here[1] + sum[1] / count]
        })
        .collect()
}

/// `points` with every curl cut out: where a segment crosses one of the segments before it
/// within [`CURL_MAX_LENGTH`] of path and the loop between them encloses less than
/// `least_area`, the loop is replaced by the crossing. Under the strokes file's even-odd rule a
/// tremor's curl would be a hole in the lasso, or a speck of the outside in it.
pub fn uncurled(points: &[[f32; 2]], least_area: f32) -> Vec<[f32; 2]> {
    let mut path: Vec<[f32; 2]> = Vec::with_capacity(points.len());
    // The path's length from its first point to each of its points.
    let mut along: Vec<f32> = Vec::with_capacity(points.len());
    for &point in points {
        let n = path.len();
        if n >= 3 {
            let last = path[n - 1];
            // Segments (j, j + 1) that do not touch the new one, nearest first.
            let mut curl = None;
            for j in (0..n - 2).rev() {
                if along[n - 1] - along[j + 1] > CURL_MAX_LENGTH {
                    break;
                }
                let Some(crossing) = crossing_point((path[j], path[j + 1]), (last, point)) else { continue };
                let mut inner = vec![crossing];
                inner.extend_from_slice(&path[j + 1..]);
                if enclosed_area(&inner) < least_area {
                    curl = Some((j, crossing));
                }
                break;
            }
            if let Some((j, crossing)) = curl {
                path.truncate(j + 1);
                along.truncate(j + 1);
                if path.last() != Some(&crossing) {
                    push_along(&mut path, &mut along, crossing);
                }
            }
        }
        push_along(&mut path, &mut along, point);
    }
    path
}

/// Appends `point` to `path`, and its length along the path to `along`.
fn push_along(path: &mut Vec<[f32; 2]>, along: &mut Vec<f32>, point: [f32; 2]) {
    let length = match (path.last(), along.last()) {
        (Some(last), Some(&so_far)) => so_far + (point[0] - last[0]).hypot(point[1] - last[1]),
        _ => 0.0,
    };
    path.push(point);
    along.push(length);
}

/// A loop within a path: where the path crosses itself (if it closes there) and the runs of the
/// path's points that go round from there. Found on one rendition of a path (a steadied one),
/// it is drawn through the points of another with the same indices ([`PathLoop::on`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PathLoop {
    /// The crossing that closes the loop; `None` for a loop that closes where the path comes back
    /// near a point of its own (by the edge back to it).
    pub crossing: Option<[f32; 2]>,
    /// The indices of the points that go round, in order: one run, or two for a loop that goes
    /// over the end of a closed path to its start.
    pub runs: [std::ops::Range<usize>; 2],
}

impl PathLoop {
    /// The loop's polygon through `points`: its crossing, then its runs' points.
    pub fn on(&self, points: &[[f32; 2]]) -> Vec<[f32; 2]> {
        let mut polygon: Vec<[f32; 2]> = self.crossing.into_iter().collect();
        for run in &self.runs {
            polygon.extend_from_slice(&points[run.clone()]);
        }
        polygon
    }

    fn run(crossing: Option<[f32; 2]>, run: std::ops::Range<usize>) -> PathLoop {
        PathLoop { crossing, runs: [run, 0..0] }
    }
}

/// Every loop within the path (module doc): those its crossings close, and the prefixes and
/// suffixes that end where the path comes back within `close_fraction` of their extent (the
/// larger side of their bounding box) of their first point. The whole path is not among them;
/// a scribble (more than [`MAX_CROSSINGS`] crossings) has none. Loops closed by crossings that
/// enclose less than `least_area` within [`CURL_MAX_LENGTH`] of path are curls, left out.
pub fn loops_within(points: &[[f32; 2]], closed: bool, close_fraction: f32, least_area: f32) -> Vec<PathLoop> {
    let Some(mut loops) = crossing_loops(points, closed, least_area) else {
        return Vec::new();
    };
    for end in returns_to_start(points, close_fraction) {
        loops.push(PathLoop::run(None, 0..end + 1));
    }
    let reversed: Vec<[f32; 2]> = points.iter().rev().copied().collect();
    let n = points.len();
    for end in returns_to_start(&reversed, close_fraction) {
        loops.push(PathLoop::run(None, n - 1 - end..n));
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
/// [`MAX_CROSSINGS`] crossings). A crossing that closes a curl (less than `least_area` within
/// [`CURL_MAX_LENGTH`] of path) closes nothing and is not counted.
pub fn crossing_loops(points: &[[f32; 2]], closed: bool, least_area: f32) -> Option<Vec<PathLoop>> {
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
    // The path's length from its first point to the start of each segment (and to the end).
    let mut along = Vec::with_capacity(segments + 1);
    along.push(0.0f32);
    for s in 0..segments {
        let (a, b) = end(s);
        along.push(along[s] + (b[0] - a[0]).hypot(b[1] - a[1]));
    }
    let mut loops = Vec::new();
    // Where each counted crossing lies along the path, on its earlier and its later segment.
    let mut counted: Vec<(f32, f32)> = Vec::new();
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
            let inner = PathLoop::run(Some(crossing), k + 1..m + 1);
            if along[m + 1] - along[k] <= CURL_MAX_LENGTH && enclosed_area(&inner.on(points)) < least_area {
                continue;
            }
            // A finger running along its own path (past its start, round a second time) crosses
            // it again and again, each loop the last one give or take a sliver: one is enough.
            let near = |(earlier, later): &(f32, f32)| {
                (earlier - along[k]).abs() <= CURL_MAX_LENGTH && (later - along[m]).abs() <= CURL_MAX_LENGTH
            };
            if counted.iter().any(near) {
                continue;
            }
            counted.push((along[k], along[m]));
            loops.push(inner);
            if closed {
                loops.push(PathLoop { crossing: Some(crossing), runs: [m + 1..n, 0..k + 1] });
            }
            if counted.len() > MAX_CROSSINGS {
                return None;
            }
        }
    }
    Some(loops)
}

/// The area a polygon encloses, closed by the edge from its last point back to its first
/// (shoelace, absolute; in f64 and about its first point, so that long paths far from the
/// origin keep their area).
pub fn enclosed_area(points: &[[f32; 2]]) -> f32 {
    let Some(&first) = points.first() else { return 0.0 };
    let relative = |p: &[f32; 2]| [(p[0] - first[0]) as f64, (p[1] - first[1]) as f64];
    let twice: f64 = points
        .iter()
        .zip(points.iter().cycle().skip(1))
        .map(|(a, b)| {
            let (a, b) = (relative(a), relative(b));
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    (twice.abs() / 2.0) as f32
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
        assert_eq!(crossing_loops(&circle(0.95, 64, 50.0), true, 64.0), Some(Vec::new()));
        assert_eq!(crossing_loops(&circle(0.95, 64, 50.0), false, 64.0), Some(Vec::new()));
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
        let loops: Vec<_> =
            crossing_loops(&path, false, 64.0).expect("one crossing").iter().map(|l| l.on(&path)).collect();
        assert_eq!(loops.len(), 1, "{loops:?}");
        // The full turn: 64 points and the crossing.
        assert!((64..=66).contains(&loops[0].len()), "{}", loops[0].len());
        // Closed, the overshoot with the closing edge is the other loop.
        let closed: Vec<_> =
            crossing_loops(&path, true, 64.0).expect("one crossing").iter().map(|l| l.on(&path)).collect();
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
        assert_eq!(crossing_loops(&spiral, false, 64.0), Some(Vec::new()));
        let loops: Vec<_> = loops_within(&spiral, false, 0.35, 64.0).iter().map(|l| l.on(&spiral)).collect();
        // The first turn as a prefix (65 points), and the last turn as a suffix.
        assert!(
            loops.iter().any(|l| l.len() == 65 && l[0] == spiral[0]),
            "{:?}",
            loops.iter().map(Vec::len).collect::<Vec<_>>()
        );
        assert!(loops.iter().any(|l| l.len() == 65 && l.last() == Some(&spiral[128])));
    }

    #[test]
    fn a_tail_before_the_loop_is_left_off_by_a_suffix() {
        // From the centre out to the rim, then round, ending just short of where the tail met it.
        let mut path: Vec<[f32; 2]> = (0..10).map(|k| [100.0 + 5.0 * k as f32, 100.0]).collect();
        path.extend(circle(0.97, 64, 50.0));
        let loops: Vec<_> = loops_within(&path, false, 0.35, 64.0).iter().map(|l| l.on(&path)).collect();
        assert!(loops.iter().any(|l| l.last() == path.last() && (60..=64).contains(&l.len())), "{loops:?}");
    }

    #[test]
    fn a_figure_eight_splits_at_its_waist_into_its_lobes() {
        let eight: Vec<[f32; 2]> = (0..=64)
            .map(|k| {
                let t = k as f32 / 64.0 * std::f32::consts::TAU;
                [100.0 + 60.0 * t.sin(), 100.0 + 30.0 * (2.0 * t).sin()]
            })
            .collect();
        let loops: Vec<_> =
            crossing_loops(&eight, true, 64.0).expect("one crossing").iter().map(|l| l.on(&eight)).collect();
        assert!(!loops.is_empty());
        for lobe in &loops {
            let xs: Vec<f32> = lobe.iter().map(|p| p[0]).collect();
            let (low, high) = xs.iter().fold((f32::MAX, f32::MIN), |(l, h), &x| (l.min(x), h.max(x)));
            assert!(low >= 99.0 || high <= 101.0, "a lobe crosses the waist: {low}..{high}");
        }
    }

    #[test]
    fn a_tremor_s_curls_close_no_loop() {
        // Most of a circle with a curl of 3 px every eighth point: a shaking fingertip.
        let mut path = Vec::new();
        for (k, point) in circle(0.95, 64, 50.0).into_iter().enumerate() {
            path.push(point);
            if k % 8 == 4 {
                path.extend([
                    [point[0] + 3.0, point[1]],
                    [point[0] + 3.0, point[1] + 3.0],
                    [point[0] - 1.0, point[1] + 1.0],
                ]);
            }
        }
        assert!(crossing_loops(&path, true, 64.0).expect("curls are not crossings").is_empty());
    }

    #[test]
    fn a_curl_is_cut_out_of_the_path_and_a_loop_is_not() {
        // Along the top of a square, a curl of 4 x 4 px; then round the square.
        let path = [
            [0.0, 0.0],
            [50.0, 0.0],
            [54.0, 4.0],
            [54.0, -4.0],
            [48.0, 2.0],
            [100.0, 0.0],
            [100.0, 100.0],
            [0.0, 100.0],
        ];
        let plain = uncurled(&path, 64.0);
        assert!(!plain.contains(&[54.0, 4.0]) && !plain.contains(&[54.0, -4.0]), "{plain:?}");
        assert!(crossing_loops(&plain, true, 0.0).expect("no scribble").is_empty(), "{plain:?}");
        assert!((enclosed_area(&plain) - 10_000.0).abs() < 64.0, "{}", enclosed_area(&plain));
        // A loop larger than the least area stays.
        assert_eq!(uncurled(&path, 4.0), path.to_vec());
    }

    #[test]
    fn a_path_that_runs_along_itself_closes_one_loop_however_often_it_crosses() {
        // A turn and a half, the second pass zigzagging across the first: 40 crossings or so.
        let path: Vec<[f32; 2]> = circle(1.5, 64, 50.0)
            .into_iter()
            .enumerate()
            .map(|(k, [x, y])| {
                let radius = if k > 64 { 50.0 + if k % 2 == 0 { 2.0 } else { -2.0 } } else { 50.0 };
                [100.0 + (x - 100.0) * radius / 50.0, 100.0 + (y - 100.0) * radius / 50.0]
            })
            .collect();
        let loops = crossing_loops(&path, false, 64.0).expect("not a scribble");
        assert!((1..=MAX_CROSSINGS).contains(&loops.len()), "{}", loops.len());
        assert!(loops.iter().all(|l| (60..=70).contains(&l.on(&path).len())));
    }

    #[test]
    fn steadying_averages_out_jitter_and_keeps_the_ends() {
        let jittered: Vec<[f32; 2]> = (0..100).map(|k| [k as f32 * 1.5, if k % 2 == 0 { 2.0 } else { -2.0 }]).collect();
        let steady = steadied(&jittered, 8.0);
        assert_eq!((steady[0], steady[99]), (jittered[0], jittered[99]));
        assert!(steady[5..95].iter().all(|p| p[1].abs() < 0.5), "{steady:?}");
        // A loop much larger than the reach keeps its size.
        let round = circle(0.95, 64, 50.0);
        assert!(steadied(&round, 8.0).iter().all(|&[x, y]| ((x - 100.0).hypot(y - 100.0) - 50.0).abs() < 1.0));
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
        assert_eq!(crossing_loops(&scribble, false, 64.0), None);
        assert!(loops_within(&scribble, true, 0.35, 64.0).is_empty());
        assert_eq!(crossing_loops(&scribble[..2], true, 64.0), Some(Vec::new()));
    }
}
