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
    unix: u64,
}

/// The audit log of the data folder, written off the UI thread.
pub(crate) struct Audit {
    log: Option<AuditLog>,
    worker: Box<dyn Worker<Line, ()>>,
}

impl Audit {
    /// The log of `data_dir` (none: nothing is written), a thread per line.
    pub(crate) fn new(data_dir: Option<&std::path::Path>) -> Audit {
        let log = data_dir.map(|data_dir| AuditLog::of_writer(data_dir, KIOSK));
        let writer = log.clone();
        let task: Task<Line, ()> = Arc::new(move |line: Line, _: &Ticket, report: &Report<'_, ()>| {
            if let Some(log) = &writer {
                log.record(line.unix, line.event, line.series_uid.as_deref(), line.detail.as_deref());
            }
            report(())
        });
        Audit { log, worker: Box::new(Threaded::new("audit", task)) }
    }

    /// Records `event` now, about the series `series_uid`, with `detail` (never patient data).
    pub(crate) fn record(&mut self, event: Event, series_uid: Option<String>, detail: Option<String>) {
        if self.log.is_none() {
            return;
        }
        let unix =
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |since| since.as_secs());
        self.worker.send(Line { event, series_uid, detail, unix });
        // Answers are not awaited; each line's job ends on its own.
        while self.worker.poll().is_some() {}
    }
}
