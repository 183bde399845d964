//! Classification in the background: the defined classes' lassos train the classifier, the
//! whole volume is labelled and the classes get their harmonic styles (paper §3.4-3.5), on a
//! worker thread, so the UI thread never waits. A job reports three times: a first, coarse
//! classification as soon as the coarse grid is labelled ([`JobOutcome::Preview`]: what the 3-D
//! view shows within a fraction of a second), the exact one ([`JobOutcome::Done`]), then the
//! survey of where the classifier is unsure ([`JobOutcome::Guidance`], which nobody waits
//! for). A new job cancels the one running (new input makes the old result stale); results of
//! cancelled or superseded jobs are never shown.
//!
//! Never: touches the UI; the app polls [`ClassificationJobs::poll`] from its event loop.

use super::worker::{Delivery, Inline, Report, Threaded, Ticket, Worker};
use std::sync::Arc;
use std::time::Instant;
use volasso_core::pipeline::{self, RunControl};
use volasso_core::preset::{Modality, Preset};
use volasso_core::segmentation::{LabelVolume, SegmentationOptions, Segmenter};
use volasso_core::strokes::StrokesFile;
use volasso_core::transfer::{ClassTable, HueTemplate};
use volasso_core::uncertainty::{self, Survey};
use volasso_core::volume::Volume;

/// A finished classification as the kiosk holds it (the labels shared with the 3-D view and
/// the slices, how long it took, where it is unsure); the pipeline's own result is
/// `pipeline::Classified`.
#[derive(Clone, Debug)]
pub struct ClassificationResult {
    pub labels: Arc<Vec<u8>>,
    pub table: ClassTable,
    /// From "define class" to the result, training and labelling included.
    pub seconds: f64,
    pub classified_voxels: usize,
    /// Where the classifier is unsure (the slices' tint, "Draw here next"); `None` when the
    /// survey failed (logged).
    pub guidance: Option<Arc<Guidance>>,
}

/// The trained classifier kept with its result, and the survey of its margins
/// ([`uncertainty::survey`]).
pub struct Guidance {
    pub segmenter: Arc<Segmenter>,
    pub survey: Survey,
}

impl std::fmt::Debug for Guidance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Guidance").field("survey", &self.survey).finish_non_exhaustive()
    }
}

/// What a job reports.
#[derive(Debug)]
pub enum JobOutcome {
    /// A first look: the coarse grid's labels, the exact ones still to come.
    Preview(ClassificationResult),
    /// The exact classification (without its guidance, which follows).
    Done(ClassificationResult),
    /// Where the classifier of the last [`JobOutcome::Done`] is unsure.
    Guidance(Arc<Guidance>),
    Failed(String),
}

/// The classes a classification of `strokes` (with `preset`, if one is applied) is of, in
/// class order: the preset's, then the drawn ones it lacks.
pub fn class_names(preset: Option<&AppliedPreset>, strokes: &StrokesFile) -> Vec<String> {
    let drawn: Vec<String> = strokes.classes.iter().map(|class| class.name.clone()).collect();
    match preset {
        Some(applied) => volasso_core::preset::joined_classes(&applied.preset.class_names(), &drawn).0,
        None => drawn,
    }
}

/// One classification to run: the volume, the classes' lassos, the preset they add to (if
/// one was applied), the colour template and how to segment.
pub struct ClassifyJob {
    pub volume: Arc<Volume>,
    pub strokes: StrokesFile,
    pub preset: Option<AppliedPreset>,
    pub template: HueTemplate,
    pub options: SegmentationOptions,
}

/// A learned preset applied to the open scan, and what the scan is (a preset of one modality
/// refuses the other).
#[derive(Clone, Debug)]
pub struct AppliedPreset {
    pub preset: Arc<Preset>,
    pub modality: Modality,
}

/// Starts, cancels and collects classification jobs; one runs at a time.
pub struct ClassificationJobs {
    worker: Box<dyn Worker<ClassifyJob, JobOutcome>>,
    /// The generation of the job whose result is awaited.
    running: Option<u64>,
    /// The generation of the last job that finished: its guidance is still welcome.
    finished: Option<u64>,
    /// How every job segments: the default.
    options: SegmentationOptions,
}

impl Default for ClassificationJobs {
    fn default() -> Self {
        ClassificationJobs::over(Box::new(Threaded::new("classify", Arc::new(run_job))))
    }
}

impl ClassificationJobs {
    /// Jobs run on the caller's thread at the next poll ([`Inline`]): the app's logic tests
    /// classify without a worker thread.
    pub fn inline() -> ClassificationJobs {
        ClassificationJobs::over(Box::new(Inline::new(Arc::new(run_job))))
    }

    /// Jobs run by `worker`.
    pub fn over(worker: Box<dyn Worker<ClassifyJob, JobOutcome>>) -> ClassificationJobs {
        ClassificationJobs { worker, running: None, finished: None, options: SegmentationOptions::default() }
    }

    /// Classifies `volume` (of `modality`: an MR scan's shading is divided out) with the
    /// classes of `strokes` (added to `preset`'s, when given), cancelling any job still running.
    pub fn start(
        &mut self,
        volume: Arc<Volume>,
        modality: Modality,
        strokes: StrokesFile,
        preset: Option<AppliedPreset>,
        template: HueTemplate,
    ) {
        self.cancel();
        let options = SegmentationOptions { correct_shading: modality == Modality::Mr, ..self.options.clone() };
        self.running = Some(self.worker.send(ClassifyJob { volume, strokes, preset, template, options }));
    }

    /// Stops the running job, if any; its result will not be reported.
    pub fn cancel(&mut self) {
        if self.running.take().is_some() {
            self.worker.cancel();
        }
    }

    pub fn busy(&self) -> bool {
        self.running.is_some()
    }

    /// The running job's progress in 0..=1.
    pub fn progress(&self) -> Option<f32> {
        self.running.and(self.worker.progress())
    }

    /// The next report of the running job (or the guidance of the last one done); never
    /// blocks. The job stops running at its [`JobOutcome::Done`] or [`JobOutcome::Failed`].
    pub fn poll(&mut self) -> Option<JobOutcome> {
        loop {
            let Some(Delivery { generation, output }) = self.worker.poll() else {
                // A job that ended without a word (its thread could not start) must not leave
                // "Classifying..." on screen for ever.
                while let Some(generation) = self.worker.ended_silently() {
                    if self.running == Some(generation) {
                        self.running = None;
                        self.finished = Some(generation);
                        return Some(JobOutcome::Failed(
                            "the classifier stopped without a result (see the log)".into(),
                        ));
                    }
                }
                return None;
            };
            let current = self.running == Some(generation);
            match output {
                JobOutcome::Guidance(_) if self.finished == Some(generation) => return Some(output),
                JobOutcome::Preview(_) if current => return Some(output),
                JobOutcome::Done(_) | JobOutcome::Failed(_) if current => {
                    self.running = None;
                    self.finished = Some(generation);
                    return Some(output);
                }
                _ => {}
            }
        }
    }
}

/// A worker's job: classifies, reports the result, then the survey of where it is unsure. A
/// panic in the pipeline is reported as a failure, so the app hears of it instead of
/// "Classifying..." forever.
fn run_job(job: ClassifyJob, ticket: &Ticket, report: &Report<'_, JobOutcome>) {
    let ClassifyJob { volume, strokes, preset, template, options } = job;
    let run = || classify(&volume, &strokes, preset.as_ref(), template, &options, ticket, report);
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)) {
        Ok(Ok((classified, segmenter))) => {
            report(JobOutcome::Done(classified.clone()));
            // After the result is shown: the survey is for guidance, not part of it.
            if let Some(guidance) = survey(&volume, segmenter, &classified.labels) {
                report(JobOutcome::Guidance(guidance));
            }
        }
        Ok(Err(message)) => report(JobOutcome::Failed(message)),
        Err(_) => report(JobOutcome::Failed("the classifier failed (see the log)".to_string())),
    }
}

/// Trains and labels, reporting the coarse first look through `report`; the exact result and
/// the trained classifier for the survey. With a preset, the classes of `strokes` that hold
/// lassos join its training by name (`pipeline::preset_samples`) and the colours keep its look.
fn classify(
    volume: &Volume,
    strokes: &StrokesFile,
    preset: Option<&AppliedPreset>,
    template: HueTemplate,
    options: &SegmentationOptions,
    ticket: &Ticket,
    report: &Report<'_, JobOutcome>,
) -> Result<(ClassificationResult, Segmenter), String> {
    let started = Instant::now();
    // Training is about a tenth of the work; labelling reports the rest.
    let progressed = |fraction: f32| ticket.set_progress(0.1 + 0.9 * fraction.clamp(0.0, 1.0));
    let class_count = class_names(preset, strokes).len();
    let table_of = |labels: &[u8]| {
        let mut table = ClassTable::compute(volume, labels, class_count, template)?;
        if let Some(applied) = preset {
            applied.preset.restyle(&mut table);
        }
        Ok::<_, volasso_core::transfer::TransferError>(table)
    };
    let preview = |coarse: &LabelVolume| match table_of(&coarse.labels) {
        Ok(table) => {
            log::info!("first look in {:.0} ms", started.elapsed().as_secs_f64() * 1000.0);
            report(JobOutcome::Preview(ClassificationResult {
                labels: Arc::new(coarse.labels.clone()),
                table,
                seconds: started.elapsed().as_secs_f64(),
                classified_voxels: coarse.classified_voxels,
                guidance: None,
            }));
        }
        Err(error) => log::warn!("no first look: {error}"),
    };
    let control = RunControl { progress: &progressed, cancel: ticket.cancel_flag(), preview: Some(&preview) };
    let applied = preset.map(|applied| (applied.preset.as_ref(), applied.modality));
    let classified = pipeline::classify_strokes_with_preset(volume, strokes, applied, options, Some(template), control)
        .map_err(|e| e.to_string())?;
    let labelled = classified.labels;
    let result = ClassificationResult {
        labels: Arc::new(labelled.labels),
        table: classified.table,
        seconds: started.elapsed().as_secs_f64(),
        classified_voxels: labelled.classified_voxels,
        guidance: None,
    };
    Ok((result, classified.segmenter))
}

/// Where `segmenter` is unsure on `labels` ([`uncertainty::survey`]); `None` when the survey
/// failed (logged).
fn survey(volume: &Volume, segmenter: Segmenter, labels: &[u8]) -> Option<Arc<Guidance>> {
    let surveyed = Instant::now();
    match uncertainty::survey(volume, &segmenter, labels) {
        Ok(survey) => {
            log::info!(
                "unsure survey: {} of {} voxels (every {}th) unsure below margin {:.3}, {:.0} ms",
                survey.unsure,
                survey.evaluated,
                survey.stride,
                survey.threshold,
                surveyed.elapsed().as_secs_f64() * 1000.0
            );
            Some(Arc::new(Guidance { segmenter: Arc::new(segmenter), survey }))
        }
        Err(error) => {
            log::warn!("cannot survey where the classifier is unsure: {error}");
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;
    use volasso_core::phantom::{demo_foot_with, lassos_inside};

    /// The job's outcomes until it ends (its Done or Failed last).
    fn wait_for_end(jobs: &mut ClassificationJobs) -> Vec<JobOutcome> {
        let mut outcomes = Vec::new();
        for _ in 0..6000 {
            if let Some(outcome) = jobs.poll() {
                let ended = matches!(outcome, JobOutcome::Done(_) | JobOutcome::Failed(_));
                outcomes.push(outcome);
                if ended {
                    return outcomes;
                }
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        panic!("the job did not finish in a minute");
    }

    fn wait(jobs: &mut ClassificationJobs) -> JobOutcome {
        wait_for_end(jobs).pop().expect("an outcome")
    }

    #[test]
    fn a_job_labels_the_phantom_and_a_superseded_job_is_never_reported() {
        let phantom = demo_foot_with([96, 64, 48], 7).unwrap();
        let strokes = lassos_inside(&phantom, &[1, 2], 4, 2.5);
        let volume = Arc::new(phantom.volume);
        let mut jobs = ClassificationJobs::default();
        jobs.start(volume.clone(), Modality::Ct, strokes.clone(), None, HueTemplate::default_for(2));
        jobs.start(volume.clone(), Modality::Ct, strokes, None, HueTemplate::default_for(2));
        assert!(jobs.busy());
        let mut outcomes = wait_for_end(&mut jobs);
        let classified = match outcomes.pop() {
            Some(JobOutcome::Done(classified)) => classified,
            other => panic!("the job did not end with a result: {other:?}"),
        };
        assert_eq!(classified.labels.len(), volume.voxel_count());
        assert_eq!(classified.table.styles.len(), 2);
        assert!(!jobs.busy());
        // Before it, one first look of the same size; the cancelled job reported nothing.
        let [JobOutcome::Preview(first)] = outcomes.as_slice() else { panic!("{outcomes:?}") };
        assert_eq!(first.labels.len(), volume.voxel_count());
        assert!(first.seconds <= classified.seconds);
        let agree = first.labels.iter().zip(classified.labels.iter()).filter(|(a, b)| a == b).count();
        assert!(agree * 10 > volume.voxel_count() * 9, "the first look agrees on {agree} voxels");
        // Then the survey of the finished job, and nothing of the cancelled one.
        let mut guidance = None;
        for _ in 0..6000 {
            match jobs.poll() {
                Some(JobOutcome::Guidance(survey)) => {
                    guidance = Some(survey);
                    break;
                }
                Some(other) => panic!("only the guidance may follow: {other:?}"),
                None => std::thread::sleep(Duration::from_millis(10)),
            }
        }
        assert!(guidance.is_some(), "the survey follows the result");
        std::thread::sleep(Duration::from_millis(50));
        assert!(jobs.poll().is_none(), "the first, cancelled job must not be reported");
    }

    #[test]
    fn a_bad_training_set_fails_with_a_message() {
        let phantom = demo_foot_with([24, 16, 12], 7).unwrap();
        let mut strokes = lassos_inside(&phantom, &[1, 2], 4, 2.5);
        strokes.classes[1].strokes.clear();
        let mut jobs = ClassificationJobs::default();
        jobs.start(Arc::new(phantom.volume), Modality::Ct, strokes, None, HueTemplate::default_for(2));
        let JobOutcome::Failed(message) = wait(&mut jobs) else { panic!("an empty class must fail") };
        assert!(message.contains("Class") || message.contains("class"), "{message}");
    }
}
