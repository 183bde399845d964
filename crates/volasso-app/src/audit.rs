//! The kiosk's lines in the appliance's audit log (`volasso_appliance::audit`): a scan opened
//! (the PACS worker writes its retrievals and sends, the expiry worker what it deleted). Written
//! on a worker, as the log flushes each line to disk.
//!
//! Never: writes on the UI thread, or anything without a data folder.

use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use std::sync::Arc;
use volasso_appliance::audit::{AuditLog, Event};

/// The kiosk's file in the audit folder (`kiosk.log`): the kiosk, its PACS worker, its sweep
/// and its snapshots write it.
pub(crate) const KIOSK: &str = "kiosk";

/// One line to write.
pub(crate) struct Line {
    event: Event,
    series_uid: Option<String>,
    detail: Option<String>,
}

/// The audit log of the data folder, written off the UI thread.
pub(crate) struct Audit {
    /// `None` without a data folder: nothing is written.
    worker: Option<Box<dyn Worker<Line, ()>>>,
}

impl Audit {
    /// The log of `data_dir` (none: nothing is written), a thread per line.
    pub(crate) fn new(data_dir: Option<&std::path::Path>) -> Audit {
        let worker = data_dir.map(|data_dir| {
            let log = AuditLog::of_writer(data_dir, KIOSK);
            let task: Task<Line, ()> = Arc::new(move |line: Line, _: &Ticket, report: &Report<'_, ()>| {
                log.record_now(line.event, line.series_uid.as_deref(), line.detail.as_deref());
                report(())
            });
            Box::new(Threaded::new("audit", task)) as Box<dyn Worker<Line, ()>>
        });
        Audit { worker }
    }

    /// Records `event` now, about the series `series_uid`, with `detail` (never patient data).
    pub(crate) fn record(&mut self, event: Event, series_uid: Option<String>, detail: Option<String>) {
        let Some(worker) = &mut self.worker else { return };
        worker.send(Line { event, series_uid, detail });
        // Answers are not awaited; each line's job ends on its own.
        while worker.poll().is_some() {}
    }
}
