use super::*;
use crate::controller::ControllerWorkers;
use crate::view3d::ViewRenderer;
use crate::worker::Inline;

const TICK: Duration = Duration::from_millis(16);

/// An attract mode whose loader runs inline and whose renderer answers at once, without a GPU.
fn attract() -> Attract {
    Attract::with_workers(Workers {
        loader: |options| Box::new(Inline::new(open_task(options))),
        controller: || {
            let workers = ControllerWorkers { renderer: ViewRenderer::blank_pictures(), ..ControllerWorkers::inline() };
            Controller::with_workers(None, workers)
        },
    })
}

/// Ticks from `now` until the phase is `phase` (at most `limit` ticks); the time of the tick
/// that got there.
fn tick_until(attract: &mut Attract, mut now: Duration, phase: &str, limit: usize) -> Duration {
    for _ in 0..limit {
        assert_eq!(attract.tick(now), None, "nothing shown while preparing");
        if attract.describe() == phase {
            return now;
        }
        now += TICK;
    }
    panic!("still {} after {limit} ticks, waiting for {phase}", attract.describe());
}

/// The pictures shown from `from` to `to`, with the times they were shown.
fn shown(attract: &mut Attract, from: Duration, to: Duration) -> Vec<(Duration, Shown)> {
    let mut shown = Vec::new();
    let mut now = from;
    while now < to {
        if let Some(picture) = attract.tick(now) {
            shown.push((now, picture));
        }
        now += TICK;
    }
    shown
}

#[test]
fn with_an_empty_gallery_the_demo_turns_once_prepared_two_pictures_a_second() {
    let mut attract = attract();
    assert_eq!(attract.describe(), "off");
    let demo = what_to_show(None).expect("the demo's lassos parse");
    assert_eq!(demo.name, VolumeSource::Demo.name());
    attract.begin(demo, 64, OpenOptions::default(), Duration::ZERO);
    assert_eq!(attract.describe(), "loading");
    assert!(attract.busy());
    let start = tick_until(&mut attract, Duration::ZERO, "playing", 1_000);
    assert!(!attract.busy());
    let turn = shown(&mut attract, start, start + Duration::from_secs(15));
    assert_eq!(turn.len(), FRAMES, "one turn in 15 s");
    for (index, (at, picture)) in turn.iter().enumerate() {
        let due = start + Duration::from_millis(500) * index as u32;
        assert!(*at >= due && *at < due + TICK, "picture {index} at {at:?}, due {due:?}");
        assert_eq!((picture.frame.width(), picture.frame.height()), (64, 64));
        assert_eq!(picture.caption, VolumeSource::Demo.name());
    }
    let mut sides: Vec<u8> = turn.iter().map(|(_, picture)| picture.frame.get_pixel(0, 0).0[0]).collect();
    sides.dedup();
    assert_eq!(sides.len(), FRAMES, "each picture from its own side: {sides:?}");
    // The turn goes round again.
    let again = shown(&mut attract, start + Duration::from_secs(15), start + Duration::from_secs(16));
    assert_eq!(again[0].1.frame, turn[0].1.frame);
}

#[test]
fn the_next_idle_period_plays_the_kept_turn_at_once_and_another_size_prepares_anew() {
    let mut attract = attract();
    let demo = what_to_show(None).expect("the demo's lassos parse");
    attract.begin(demo.clone(), 64, OpenOptions::default(), Duration::ZERO);
    let start = tick_until(&mut attract, Duration::ZERO, "playing", 1_000);
    let first = shown(&mut attract, start, start + TICK);
    attract.end();
    assert_eq!(attract.describe(), "off");
    assert_eq!(attract.tick(start + Duration::from_secs(1)), None, "nothing shown once ended");
    let later = start + Duration::from_secs(300);
    attract.begin(demo.clone(), 64, OpenOptions::default(), later);
    assert_eq!(attract.describe(), "playing", "nothing opened or rendered again");
    let replayed = shown(&mut attract, later, later + TICK);
    assert_eq!(replayed[0].1.frame, first[0].1.frame);
    attract.end();
    attract.begin(demo, 96, OpenOptions::default(), later);
    assert_eq!(attract.describe(), "loading", "another size is rendered anew");
}

#[test]
fn ending_while_preparing_keeps_nothing_and_a_scan_that_cannot_open_leaves_the_screen_still() {
    let mut attract = attract();
    let demo = what_to_show(None).expect("the demo's lassos parse");
    attract.begin(demo.clone(), 64, OpenOptions::default(), Duration::ZERO);
    attract.end();
    attract.begin(demo.clone(), 64, OpenOptions::default(), Duration::ZERO);
    assert_eq!(attract.describe(), "loading", "no turn was kept from an unfinished one");
    attract.end();
    let missing = Showing {
        session: SavedSession {
            volume: VolumeSource::Path("/nonexistent/volasso/scan.nrrd".into()).key(),
            ..demo.session.clone()
        },
        name: "Saved result: scan.nrrd".into(),
        ..demo
    };
    attract.begin(missing, 64, OpenOptions::default(), Duration::ZERO);
    let now = tick_until(&mut attract, Duration::ZERO, "off", 100);
    assert_eq!(shown(&mut attract, now, now + Duration::from_secs(2)), Vec::new());
}
