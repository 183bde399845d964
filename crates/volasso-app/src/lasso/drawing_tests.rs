use super::*;
use volasso_core::volume::PatientOrientation;

/// A path through `points` (fractions of a picture shown `picture_px` large), drawn evenly
/// over `milliseconds`, with every segment cut into 10 steps as a finger would report it.
fn drawn(points: &[[f32; 2]], picture_px: [f32; 2], milliseconds: f64) -> FingerPath {
    drawn_after(None, points, picture_px, 1000.0, milliseconds)
}

/// [`drawn`] from `start_ms`, landing where `broken_off` may go on.
fn drawn_after(
    broken_off: Option<FingerPath>,
    points: &[[f32; 2]],
    picture_px: [f32; 2],
    start_ms: f64,
    milliseconds: f64,
) -> FingerPath {
    let mut dense = vec![points[0]];
    for pair in points.windows(2) {
        for step in 1..=10 {
            let t = step as f32 / 10.0;
            dense.push([pair[0][0] + (pair[1][0] - pair[0][0]) * t, pair[0][1] + (pair[1][1] - pair[0][1]) * t]);
        }
    }
    let mut path = FingerPath::resumed_or_new(broken_off, picture_px, dense[0], start_ms);
    let steps = (dense.len() - 1).max(1) as f64;
    for (k, &point) in dense.iter().enumerate().skip(1) {
        path.add(point, start_ms + milliseconds * k as f64 / steps);
    }
    path
}

fn stored(axis: Axis) -> SliceLayout {
    SliceLayout::new(None, axis)
}

#[test]
fn a_loop_becomes_a_lasso_in_voxel_coordinates() {
    let square = drawn(&[[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75], [0.25, 0.25]], [400.0, 160.0], 900.0);
    let PathMeaning::Lasso(lasso) = square.meaning([100, 40, 10], &stored(Axis::Z), 3) else {
        panic!("not a lasso: {:?}", square.meaning([100, 40, 10], &stored(Axis::Z), 3));
    };
    assert_eq!((lasso.axis, lasso.slice), (Axis::Z, 3));
    assert_eq!(lasso.points[0], [24.5, 9.5]);
    assert!(lasso.points.contains(&[74.5, 29.5]));
    // Half the width and half the height of a 100 x 40 slice: 50 x 20 voxels.
    assert_eq!(lasso.selected_voxels([100, 40, 10]).len(), 50 * 20);
}

#[test]
fn the_flat_band_is_a_loop_whichever_way_and_however_fast_it_is_drawn() {
    // Around the skull's lower edge on a coronal slice: right, down a little, back left, up.
    let band = [[0.2, 0.70], [0.8, 0.70], [0.8, 0.76], [0.2, 0.76], [0.2, 0.70]];
    let reversed: Vec<[f32; 2]> = band.iter().rev().copied().collect();
    // Started on the right and left a little open, as a hurried finger does.
    let leftwards = [[0.8, 0.70], [0.2, 0.70], [0.2, 0.76], [0.78, 0.76]];
    let dims = [200, 180, 100];
    for (name, points) in [("band", band.to_vec()), ("reversed", reversed), ("leftwards", leftwards.to_vec())] {
        for milliseconds in [150.0, 2000.0] {
            let path = drawn(&points, [500.0, 250.0], milliseconds);
            match path.meaning(dims, &stored(Axis::Y), 90) {
                PathMeaning::Lasso(lasso) => assert!(!lasso.selected_voxels(dims).is_empty()),
                other => panic!("{name} in {milliseconds} ms: {other:?}"),
            }
        }
    }
}

#[test]
fn a_quick_straight_sideways_stroke_is_a_swipe_with_a_direction() {
    let dims = [64, 64, 64];
    let left = drawn(&[[0.8, 0.5], [0.5, 0.52], [0.2, 0.5]], [300.0, 300.0], 120.0);
    assert_eq!(left.meaning(dims, &stored(Axis::X), 1), PathMeaning::Swipe(1));
    let right = drawn(&[[0.2, 0.5], [0.6, 0.48]], [300.0, 300.0], 150.0);
    assert_eq!(right.meaning(dims, &stored(Axis::X), 1), PathMeaning::Swipe(-1));
}

#[test]
fn anything_else_is_unclear_and_says_why() {
    let dims = [64, 64, 64];
    let layout = stored(Axis::Z);
    let meaning =
        |points: &[[f32; 2]], milliseconds: f64| drawn(points, [300.0, 300.0], milliseconds).meaning(dims, &layout, 0);
    assert_eq!(meaning(&[[0.5, 0.5], [0.51, 0.5]], 50.0), PathMeaning::Unclear(Unclear::Tap));
    // Straight and sideways but slow: a drag, not a swipe, and not a loop.
    assert_eq!(meaning(&[[0.2, 0.5], [0.8, 0.5]], 2000.0), PathMeaning::Unclear(Unclear::Open));
    // Quick and straight but vertical; a bent open stroke (an L).
    assert_eq!(meaning(&[[0.5, 0.2], [0.5, 0.8]], 100.0), PathMeaning::Unclear(Unclear::Open));
    assert_eq!(meaning(&[[0.2, 0.2], [0.2, 0.8], [0.8, 0.8]], 150.0), PathMeaning::Unclear(Unclear::Open));
    // Back and forth along a line: closed, but nothing inside.
    assert_eq!(meaning(&[[0.2, 0.5], [0.8, 0.5], [0.21, 0.5]], 300.0), PathMeaning::Unclear(Unclear::NoArea));
    // A loop between voxel centres (a 2-voxel slice shown 300 px large): no voxel inside.
    let between = drawn(&[[0.3, 0.3], [0.7, 0.3], [0.7, 0.7], [0.3, 0.7], [0.3, 0.3]], [300.0, 300.0], 500.0);
    assert_eq!(between.meaning([2, 2, 1], &layout, 0), PathMeaning::Unclear(Unclear::TooSmall));
    let square = drawn(&[[0.2, 0.2], [0.6, 0.2], [0.6, 0.6], [0.2, 0.6], [0.2, 0.2]], [300.0, 300.0], 500.0);
    assert_eq!(square.meaning(dims, &layout, 64), PathMeaning::Unclear(Unclear::NoSlice));
    for unclear in [Unclear::Tap, Unclear::Open, Unclear::NoArea, Unclear::TooSmall, Unclear::NoSlice] {
        assert!(unclear.message().starts_with("Draw a closed loop around the structure"));
    }
}

#[test]
fn a_lasso_drawn_on_a_flipped_and_turned_panel_selects_the_voxels_under_the_finger() {
    // A sagittally stored MRI: x toward anterior, y toward inferior, z toward the left. Every
    // panel is turned or flipped on screen.
    let orientation = PatientOrientation::new([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]], None).unwrap();
    let dims = [12, 16, 20];
    for axis in Axis::ALL {
        let layout = SliceLayout::new(Some(&orientation), axis);
        assert!(layout.across_reversed || layout.down_reversed || layout.transposed(), "{axis}: {layout:?}");
        let [width, height] = layout.screen_size(dims);
        // Screen pixels 2..=5 across and 3..=8 down: a rectangle with edges between centres,
        // drawn on the picture shown 10 px per voxel.
        let (u0, u1, v0, v1) = (1.5f32, 5.5f32, 2.5f32, 8.5f32);
        let fraction = |u: f32, v: f32| [(u + 0.5) / width as f32, (v + 0.5) / height as f32];
        let corners = [fraction(u0, v0), fraction(u1, v0), fraction(u1, v1), fraction(u0, v1), fraction(u0, v0)];
        let path = drawn(&corners, [10.0 * width as f32, 10.0 * height as f32], 800.0);
        let PathMeaning::Lasso(lasso) = path.meaning(dims, &layout, 4) else { panic!("{axis}: not a lasso") };
        let mut expected: Vec<usize> = (2..=5)
            .flat_map(|u| (3..=8).map(move |v| [u as f64, v as f64]))
            .map(|screen| {
                let voxel = layout.voxel_from_screen(screen, dims, 4).map(|c| c.round() as usize);
                voxel[0] + dims[0] * (voxel[1] + dims[1] * voxel[2])
            })
            .collect();
        expected.sort_unstable();
        assert_eq!(lasso.selected_voxels(dims), expected, "{axis}");
    }
}

#[test]
fn paths_are_bounded_and_ignore_non_finite_points() {
    let mut path = FingerPath::new([1000.0, 1000.0], [f32::NAN, 0.5], 0.0);
    assert!(path.points.is_empty());
    for k in 0..3 * MAX_PATH_POINTS {
        path.add([(k % 100) as f32 / 100.0, (k / 100) as f32 / 1000.0], k as f64);
    }
    assert_eq!(path.points.len(), MAX_PATH_POINTS);
    assert!(path.svg_commands().starts_with("M 0.0 0.0 L 10.0 0.0"));
    assert!(path.svg_commands().ends_with('Z'));
}

/// Points round a circle about the picture's centre, `turns` times from angle 0, the radius
/// (a fraction of the picture) changing by `drift` per turn.
fn circled(turns: f32, radius: f32, drift: f32) -> Vec<[f32; 2]> {
    let steps = (turns * 48.0).round() as usize;
    (0..=steps)
        .map(|k| {
            let turn = k as f32 / 48.0;
            let angle = turn * std::f32::consts::TAU;
            let r = radius + drift * turn;
            [0.5 + r * angle.cos(), 0.5 + r * angle.sin()]
        })
        .collect()
}

fn lassoed_count(points: &[[f32; 2]]) -> Result<usize, PathMeaning> {
    let dims = [100, 100, 10];
    match drawn(points, [400.0, 400.0], 1500.0).meaning(dims, &stored(Axis::Z), 3) {
        PathMeaning::Lasso(lasso) => Ok(lasso.selected_voxels(dims).len()),
        other => Err(other),
    }
}

#[test]
fn a_finger_that_runs_on_past_its_start_keeps_all_it_circled() {
    // One turn of radius 30 voxels: about 2,827 voxels.
    let once = lassoed_count(&circled(0.98, 0.3, 0.0)).expect("one turn");
    assert!((2700..=2900).contains(&once), "{once}");
    // A quarter and a half turn on, drifting inwards and outwards as a finger does: taken as
    // one even-odd polygon the part circled twice would be a hole (or, half a turn on, the path
    // would not count as closed at all).
    for turns in [1.25, 1.5, 2.0] {
        for drift in [-0.02, 0.02] {
            let count = lassoed_count(&circled(turns, 0.3, drift)).unwrap_or_else(|m| panic!("{turns} {drift}: {m:?}"));
            assert!(count as f32 >= 0.9 * once as f32, "{turns} turns, drift {drift}: {count} of {once}");
        }
    }
}

#[test]
fn a_finger_that_lands_inside_and_sweeps_out_before_circling_keeps_the_loop() {
    // From the centre out to the rim, once round, and up a little past the stick.
    let mut path = vec![[0.5, 0.5]];
    path.extend(circled(1.05, 0.3, 0.0));
    let count = lassoed_count(&path).expect("a lollipop is a loop");
    assert!(count >= 2600, "{count}");
}

#[test]
fn a_small_curl_on_an_open_stroke_is_not_a_loop() {
    // A slow bent stroke across the picture with a finger-sized twitch in it.
    let mut path = vec![[0.1, 0.5], [0.4, 0.55], [0.43, 0.52], [0.41, 0.5], [0.39, 0.57], [0.9, 0.7]];
    path.push([0.9, 0.9]);
    assert_eq!(lassoed_count(&path), Err(PathMeaning::Unclear(Unclear::Open)));
}

#[test]
fn a_loop_that_crosses_itself_at_a_narrow_waist_keeps_both_lobes() {
    // A twisted band: out along the top, crossing down at the waist, back along the bottom,
    // unequal lobes (as a hurried finger draws around a long thin structure).
    let band = [[0.1, 0.4], [0.6, 0.4], [0.9, 0.6], [0.9, 0.4], [0.6, 0.6], [0.1, 0.6], [0.1, 0.4]];
    let count = lassoed_count(&band).expect("the band");
    // The left lobe is about 50 x 20 voxels, the right about a third of 30 x 20.
    assert!(count > 1000 + 150, "{count}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
    /// Any path, on and off the picture, with its points in any order: one meaning, and a
    /// lasso that holds at least one voxel and only finite points.
    #[test]
    fn any_path_has_one_meaning_and_a_lasso_holds_voxels(
        points in proptest::collection::vec((-0.5f32..1.5, -0.5f32..1.5), 2..120),
        picture in 50.0f32..1200.0,
    ) {
        let points: Vec<[f32; 2]> = points.into_iter().map(|(x, y)| [x, y]).collect();
        let dims = [64, 48, 20];
        let mut path = FingerPath::new([picture, picture * 0.75], points[0], 0.0);
        for (k, &point) in points.iter().enumerate().skip(1) {
            path.add(point, 10.0 * k as f64);
        }
        if let PathMeaning::Lasso(lasso) = path.meaning(dims, &stored(Axis::Z), 7) {
            proptest::prop_assert!(lasso.points.iter().all(|p| p[0].is_finite() && p[1].is_finite()));
            proptest::prop_assert!(!lasso.selected_voxels(dims).is_empty());
        }
    }
}

#[test]
fn a_loop_drawn_in_two_strokes_with_a_skip_between_is_one_loop() {
    let dims = [100, 100, 10];
    let layout = stored(Axis::Z);
    let picture = [400.0, 400.0];
    let loop_points = circled(1.0, 0.3, 0.0);
    let (first_half, second_half) = loop_points.split_at(24);
    let first = drawn(first_half, picture, 600.0);
    assert_eq!(first.meaning(dims, &layout, 3), PathMeaning::Unclear(Unclear::Open));
    let whole = lassoed_count(&loop_points).expect("the loop in one stroke");
    // The fingertip skips: it lands again 60 ms later where it left (a pixel off).
    let mut resumed_at = second_half.to_vec();
    resumed_at[0] = [first_half[23][0] + 0.0025, first_half[23][1]];
    let end_ms = 1600.0;
    let resumed = drawn_after(Some(first.clone()), &resumed_at, picture, end_ms + 60.0, 600.0);
    let PathMeaning::Lasso(lasso) = resumed.meaning(dims, &layout, 3) else {
        panic!("{:?}", resumed.meaning(dims, &layout, 3));
    };
    assert_eq!(lasso.selected_voxels(dims).len(), whole);
    // A second later, or a finger's width away, or on a picture since enlarged: a new path.
    let late = drawn_after(Some(first.clone()), &resumed_at, picture, end_ms + 1000.0, 600.0);
    let away: Vec<[f32; 2]> = resumed_at.iter().map(|p| [p[0] - 0.15, p[1]]).collect();
    let elsewhere = drawn_after(Some(first.clone()), &away, picture, end_ms + 60.0, 600.0);
    let enlarged = drawn_after(Some(first.clone()), &resumed_at, [800.0, 800.0], end_ms + 60.0, 600.0);
    for path in [late, elsewhere, enlarged] {
        assert_ne!(path.points[0], first.points[0]);
        assert_eq!(path.meaning(dims, &layout, 3), PathMeaning::Unclear(Unclear::Open));
    }
}

#[test]
fn a_loop_cut_off_by_a_second_finger_is_told_and_a_pinch_s_first_finger_is_not() {
    let picture = [400.0, 400.0];
    // Half a loop of radius 120 px, then another hand lands.
    let half_loop = drawn(&circled(0.5, 0.3, 0.0), picture, 400.0);
    assert_eq!(half_loop.cancelled(), Some(Unclear::Interrupted));
    assert!(Unclear::Interrupted.message().contains("second touch"));
    // The first finger of a pinch moved 20 px before the second landed.
    let pinch_start = drawn(&[[0.5, 0.5], [0.55, 0.5]], picture, 50.0);
    assert_eq!(pinch_start.cancelled(), None);
}

/// [`circled`] as a shaking fingertip on a jittery panel reports it: each segment cut into
/// 10 reports (about 1.5 px apart at 400 px), each moved at random by `jitter_px` (standard
/// deviation, in x and in y).
fn shaken(points: &[[f32; 2]], jitter_px: f32, seed: u64) -> FingerPath {
    let mut rng = volasso_core::rng::SplitMix64::new(seed);
    let mut path = FingerPath::new([400.0, 400.0], points[0], 0.0);
    let mut time_ms = 0.0;
    for pair in points.windows(2) {
        for step in 1..=10 {
            let t = step as f32 / 10.0;
            let shake = [rng.next_gaussian() * jitter_px / 400.0, rng.next_gaussian() * jitter_px / 400.0];
            let [x, y] = [pair[0][0] + (pair[1][0] - pair[0][0]) * t, pair[0][1] + (pair[1][1] - pair[0][1]) * t];
            time_ms += 3.0;
            path.add([x + shake[0], y + shake[1]], time_ms);
        }
    }
    path
}

#[test]
fn a_loop_drawn_with_a_shaking_finger_keeps_all_it_circled() {
    // Jitter of 3 px between reports crosses the path over itself in tiny curls and, where it
    // runs past its start, again and again over its first stretch: read as it came, the loop
    // was a scribble or an open stroke.
    let dims = [100, 100, 10];
    let once = lassoed_count(&circled(0.98, 0.3, 0.0)).expect("one turn");
    for seed in 0..2 {
        for turns in [0.98, 1.25, 1.5, 2.0] {
            for drift in [-0.02, 0.02] {
                let path = shaken(&circled(turns, 0.3, drift), 3.0, seed);
                let PathMeaning::Lasso(lasso) = path.meaning(dims, &stored(Axis::Z), 3) else {
                    panic!("{turns} turns, drift {drift}, seed {seed}: {:?}", path.meaning(dims, &stored(Axis::Z), 3));
                };
                let count = lasso.selected_voxels(dims).len();
                assert!(
                    count as f32 >= 0.9 * once as f32,
                    "{turns} turns, drift {drift}, seed {seed}: {count} of {once}"
                );
            }
        }
    }
}
