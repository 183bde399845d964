//! Patient data that expires, on the kiosk: at start and every
//! [`retention::SWEEP_INTERVAL`] of the app's clock, the appliance's sweep
//! (`volasso_appliance::retention`) runs on a worker, sparing the scan that is open or
//! opening (it goes at the first sweep after the idle reset closes it); each thing deleted is a
//! `data-expired` line in the audit log. The chooser's next listing drops an expired scan's
//! card.
//!
//! Never: deletes on the UI thread, or anything while no retention period is set.

use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, SystemTime};
use volasso_appliance::audit::{AuditLog, Event};
use volasso_appliance::retention::{self, Expired, Sweep};

/// One sweep: where, how old is too old, and what to spare.
pub(crate) struct SweepJob {
    pub data_dir: PathBuf,
    pub session_dir: Option<PathBuf>,
    pub retention: Duration,
    pub keep: Vec<PathBuf>,
}

/// The sweep, then an audit line per thing deleted.
pub(crate) fn sweep_task() -> Task<SweepJob, Vec<Expired>> {
    Arc::new(|job: SweepJob, _: &Ticket, report: &Report<'_, Vec<Expired>>| {
        let sweep = Sweep {
            data_dir: &job.data_dir,
            session_dir: job.session_dir.as_deref(),
            retention: job.retention,
            keep: &job.keep,
        };
        let expired = sweep.run(SystemTime::now());
        let log = AuditLog::of_writer(&job.data_dir, crate::audit::KIOSK);
        for thing in &expired {
            log.record_now(Event::DataExpired, None, Some(&format!("{} {}", thing.kind.name(), thing.name)));
        }
        report(expired)
    })
}

/// When the next sweep is due, and the worker that runs it.
pub(crate) struct Expiry {
    /// `None`: data is kept.
    retention: Option<Duration>,
    next_at: Duration,
    worker: Box<dyn Worker<SweepJob, Vec<Expired>>>,
}

impl Expiry {
    /// Sweeps `retention` (none: never) on a thread per sweep, the first at once.
    pub(crate) fn new(retention: Option<Duration>) -> Expiry {
        Expiry::with_worker(retention, Box::new(Threaded::new("expiry", sweep_task())))
    }

    pub(crate) fn with_worker(retention: Option<Duration>, worker: Box<dyn Worker<SweepJob, Vec<Expired>>>) -> Expiry {
        Expiry { retention, next_at: Duration::ZERO, worker }
    }

    /// The retention period; `None`: data is kept.
    pub(crate) fn retention(&self) -> Option<Duration> {
        self.retention
    }

    /// A new retention period (the settings screen): a sweep with it is due at once.
    pub(crate) fn set_retention(&mut self, retention: Option<Duration>) {
        if retention != self.retention {
            self.retention = retention;
            self.next_at = Duration::ZERO;
        }
    }

    /// A sweep is under way (replay's `wait-idle` waits for it).
    pub(crate) fn busy(&self) -> bool {
        self.worker.busy()
    }

    /// The poll's tick at `now` (the app's clock): a sweep starts when due, with the job
    /// `job` makes from the retention period (`None`: nothing to sweep, no data folder);
    /// what a finished sweep deleted.
    pub(crate) fn tick(
        &mut self,
        now: Duration,
        job: impl FnOnce(Duration) -> Option<SweepJob>,
    ) -> Option<Vec<Expired>> {
        let finished = self.worker.poll().map(|delivery| delivery.output);
        if let Some(retention) = self.retention
            && now >= self.next_at
            && !self.worker.busy()
        {
            self.next_at = now + retention::SWEEP_INTERVAL;
            if let Some(job) = job(retention) {
                self.worker.send(job);
            }
        }
        finished.filter(|expired| !expired.is_empty())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::worker::Inline;
    use volasso_appliance::retention::Kind;

    #[test]
    fn sweeps_at_start_and_each_interval_sparing_what_the_caller_keeps() {
        let data = tempfile::tempdir().unwrap();
        let series = data.path().join("CT-0123456789abcdef");
        std::fs::create_dir(&series).unwrap();
        std::fs::write(series.join("1.dcm"), b"x").unwrap();
        std::fs::File::open(&series).unwrap().set_modified(SystemTime::now() - Duration::from_secs(48 * 3600)).unwrap();
        let mut expiry = Expiry::with_worker(Some(Duration::from_secs(24 * 3600)), Box::new(Inline::new(sweep_task())));
        let job = |keep: Vec<PathBuf>| {
            let data_dir = data.path().to_path_buf();
            move |retention| Some(SweepJob { data_dir, session_dir: None, retention, keep })
        };
        // The open scan is spared.
        assert_eq!(expiry.tick(Duration::ZERO, job(vec![series.clone()])), None);
        assert_eq!(expiry.tick(Duration::from_millis(16), job(vec![])), None, "swept, nothing deleted");
        assert!(series.exists());
        // Not due again before the interval; then due, the scan closed.
        assert_eq!(expiry.tick(Duration::from_secs(60), job(vec![])), None);
        assert!(series.exists());
        expiry.tick(retention::SWEEP_INTERVAL, job(vec![]));
        let gone = expiry.tick(retention::SWEEP_INTERVAL + Duration::from_millis(16), job(vec![])).expect("a sweep");
        assert_eq!(gone, [Expired { kind: Kind::Series, name: "CT-0123456789abcdef".into() }]);
        assert!(!series.exists());
        let audit = AuditLog::new(data.path()).entries(0).unwrap();
        assert_eq!(audit.len(), 1);
        assert_eq!(
            (audit[0].event, audit[0].detail.as_deref()),
            (Event::DataExpired, Some("series CT-0123456789abcdef"))
        );
    }

    #[test]
    fn without_a_retention_period_nothing_is_swept() {
        let mut expiry = Expiry::with_worker(None, Box::new(Inline::new(sweep_task())));
        let mut asked = false;
        expiry.tick(Duration::from_secs(3600), |_| {
            asked = true;
            None
        });
        assert!(!asked);
    }
}
