//! The PACS worker's task: C-FIND, C-GET into the data folder, and the result written as DICOM
//! (Segmentation and Secondary Capture, as `volasso export` writes them) and stored with
//! C-STORE, each behind [`volasso_dicom::pacs`] and [`volasso_dicom::dicom_out`].
//!
//! Never: reports a send as done unless the PACS stored every object, or leaves the objects it
//! wrote in the outbox after the send (they are the PACS's now, or they are retried by the
//! user, who sends again).

use super::{PacsJob, PacsReport, SendRequest};
use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use volasso_appliance::audit::{AuditLog, Event};
use volasso_dicom::dicom_out::{SourceSeries, secondary_capture, segmentation, write_object};
use volasso_dicom::pacs::{Peer, get_counting};
use volasso_dicom::receive::SeriesReport;

/// The worker that runs PACS jobs, a thread per job.
pub fn threaded() -> Box<dyn Worker<PacsJob, PacsReport>> {
    let task: Task<PacsJob, PacsReport> = Arc::new(run);
    Box::new(Threaded::new("pacs", task))
}

/// Runs one job, reporting its progress and its end.
pub fn run(job: PacsJob, _: &Ticket, report: &Report<'_, PacsReport>) {
    match job {
        PacsJob::Find { peer, query } => {
            report(PacsReport::Found(volasso_dicom::pacs::find(&peer, &query).map_err(|error| error.to_string())))
        }
        PacsJob::Get { peer, data_dir, study_uid, series_uids } => {
            // Images filed by the series before this one, and by this one so far.
            let (before, this) = (std::cell::Cell::new(0), std::cell::Cell::new(0));
            let mut reports = Vec::new();
            let mut failure = None;
            for series_uid in &series_uids {
                let stored = |count| {
                    this.set(count);
                    report(PacsReport::Stored(before.get() + count))
                };
                match get_counting(&peer, &data_dir, &study_uid, Some(series_uid), &stored) {
                    Ok(series) => {
                        audit_retrieved(&data_dir, &peer, &series);
                        reports.extend(series)
                    }
                    Err(error) => failure = Some(error.to_string()),
                }
                before.set(before.get() + this.replace(0));
            }
            let result = match failure {
                // What was published stays (it is whole); the first series that came is opened.
                Some(problem) if reports.is_empty() => Err(problem),
                _ => published(reports),
            };
            report(PacsReport::Retrieved(result))
        }
        PacsJob::Send { peer, outbox, request, audit_dir } => {
            report(PacsReport::Sent(send(&peer, &outbox, &request, audit_dir.as_deref())))
        }
    }
}

/// An audit line per series a retrieval published.
fn audit_retrieved(data_dir: &Path, peer: &Peer, reports: &[SeriesReport]) {
    let log = AuditLog::of_writer(data_dir, crate::audit::KIOSK);
    for report in reports {
        if let SeriesReport::Stored { name, series_uid, images, .. } = report {
            let detail = format!("{name}, {images} images, from {}", peer.ae_title);
            log.record_now(Event::SeriesRetrieved, Some(series_uid), Some(&detail));
        }
    }
}

/// The folders of the series a retrieval published, or why it published none.
fn published(reports: Vec<SeriesReport>) -> Result<Vec<PathBuf>, String> {
    let mut folders = Vec::new();
    let mut problems = Vec::new();
    for report in reports {
        match report {
            SeriesReport::Stored { path, .. } => folders.push(path),
            other => problems.push(format!("{other:?}")),
        }
    }
    if folders.is_empty() && !problems.is_empty() {
        log::warn!("retrieved series not published: {}", problems.join("; "));
        return Err("the retrieved images do not form a series the kiosk can open (see the log)".into());
    }
    Ok(folders)
}

/// Writes the SEG (and the SC) of `request` into a fresh folder under `outbox`, stores them on
/// `peer`, and removes the folder; the sentence for the screen. A send that went is a line in
/// the audit log of `audit_dir`.
fn send(peer: &Peer, outbox: &Path, request: &SendRequest, audit_dir: Option<&Path>) -> Result<String, String> {
    let source = SourceSeries::read(&request.folder, request.series_uid.as_deref()).map_err(|e| e.to_string())?;
    let seg = segmentation(&source, &request.labels, &request.segments).map_err(|e| e.to_string())?;
    let sc = match &request.picture {
        Some(picture) => Some(secondary_capture(&source, picture).map_err(|e| e.to_string())?),
        None => None,
    };
    let folder = outbox.join(format!("send-{}", volasso_dicom::dicom_out::new_uid("send")));
    let unwritable = |error: std::io::Error| format!("cannot write the result for sending ({error})");
    std::fs::create_dir_all(&folder).map_err(unwritable)?;
    let mut files = Vec::new();
    let mut written = Ok(());
    for (name, object) in [("segmentation.dcm", Some(&seg)), ("picture.dcm", sc.as_ref())] {
        let Some(object) = object else { continue };
        let path = folder.join(name);
        written =
            written.and_then(|()| std::fs::File::create(&path).and_then(|mut file| write_object(object, &mut file)));
        files.push(path);
    }
    let sent =
        written.map_err(unwritable).and_then(|()| volasso_dicom::pacs::send(peer, &files).map_err(|e| e.to_string()));
    if let Err(error) = std::fs::remove_dir_all(&folder) {
        log::warn!("cannot remove {}: {error}", folder.display());
    }
    let reports = sent?;
    // The objects by what they are to the user, in the order sent.
    let names = ["the segmentation", "the 3-D picture"];
    let (stored, refused): (Vec<_>, Vec<_>) = reports.iter().zip(names).partition(|(report, _)| report.stored);
    if !refused.is_empty() {
        let why = |(report, name): &(&volasso_dicom::pacs::SendReport, &str)| {
            let status = report.status.as_deref().map(|status| format!("status {status}"));
            format!("{name} ({})", report.problem.clone().or(status).unwrap_or_else(|| "no answer".into()))
        };
        let refused: Vec<String> = refused.iter().map(why).collect();
        let mut message = format!("{} refused {}", peer.ae_title, refused.join(" and "));
        if !stored.is_empty() {
            let stored: Vec<&str> = stored.iter().map(|(_, name)| *name).collect();
            message.push_str(&format!("; it stored {}", stored.join(" and ")));
        }
        return Err(message);
    }
    let what = if sc.is_some() { "segmentation and 3-D picture" } else { "segmentation" };
    if let Some(data_dir) = audit_dir {
        let detail = format!("{what} to {}", peer.ae_title);
        AuditLog::of_writer(data_dir, crate::audit::KIOSK).record_now(
            Event::ResultSent,
            Some(&source.series_uid),
            Some(&detail),
        );
    }
    Ok(format!("Sent to {}: {what} stored", peer.ae_title))
}
