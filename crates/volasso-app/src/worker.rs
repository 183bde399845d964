//! One way to run work off the UI thread. A [`Worker`] takes jobs ([`Worker::send`]), runs
//! each one, and hands back what the job reports ([`Worker::poll`], each a [`Delivery`]), stamped with the job's
//! generation; [`Worker::cancel`] stops every job sent so far, and nothing a cancelled job
//! reports is ever polled. Every background task of the app (classification, snapshots, the
//! PACS's queries, retrievals and sends ...) is a [`Task`] behind this trait, so the plumbing
//! of threads, channels, generations and cancel flags is written once, here.
//!
//! [`Threaded`] runs each job on a thread of its own; [`Inline`] runs the same task on the
//! caller's thread, at the next `poll` after `send`, so the app's tests drive the same logic
//! with no thread (and can hand in a fake task that never touches the pipeline or a GPU).
//!
//! Never: blocks in `poll`, touches the UI, or lets a panicking task take the app down (a
//! panic ends the job; its owner hears of it from [`Worker::ended_silently`], as of a job whose
//! thread could not start).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::sync::{Arc, Mutex};

/// What a running job is given besides its input: its generation, its cancel flag (set when
/// the owner cancels it) and where it writes its progress.
pub struct Ticket {
    generation: u64,
    cancel: Arc<AtomicBool>,
    /// Progress in 1/1000ths.
    progress: Arc<AtomicU32>,
    /// The newest generation sent to the worker.
    newest: Arc<AtomicU64>,
}

impl Ticket {
    fn new(generation: u64, newest: Arc<AtomicU64>) -> Ticket {
        Ticket { generation, cancel: Arc::new(AtomicBool::new(false)), progress: Arc::new(AtomicU32::new(0)), newest }
    }

    /// Whether a newer job was sent to the worker since this one: a long job of a stream of
    /// jobs (the 3-D view's frame being refined) yields to it.
    pub fn newer_sent(&self) -> bool {
        self.newest.load(Ordering::Relaxed) > self.generation
    }

    /// The job's generation: the count of jobs sent to its worker, this one included.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Whether the owner has cancelled the job: a long task checks it and stops early.
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// The flag itself, for code that takes an `&AtomicBool` (the pipeline's `RunControl`).
    pub fn cancel_flag(&self) -> &AtomicBool {
        &self.cancel
    }

    /// Records how far the job is, `fraction` in 0..=1.
    pub fn set_progress(&self, fraction: f32) {
        self.progress.store((fraction.clamp(0.0, 1.0) * 1000.0) as u32, Ordering::Relaxed);
    }

    fn shared(&self) -> Ticket {
        Ticket {
            generation: self.generation,
            cancel: self.cancel.clone(),
            progress: self.progress.clone(),
            newest: self.newest.clone(),
        }
    }
}

/// A job's work: given the job and its ticket, it reports what it has to say through the
/// callback, any number of times (a first look, then the result), and returns when done.
pub type Task<J, O> = Arc<dyn Fn(J, &Ticket, &Report<'_, O>) + Send + Sync>;

/// Where a task reports: callable from any of its threads (the pipeline's first look comes from
/// a rayon thread).
pub type Report<'a, O> = dyn Fn(O) + Sync + 'a;

/// One output of a job.
#[derive(Debug, PartialEq)]
pub struct Delivery<O> {
    /// The generation of the job that reported it ([`Worker::send`]'s answer).
    pub generation: u64,
    pub output: O,
}

/// Runs jobs in the background and hands back their reports.
pub trait Worker<J, O> {
    /// Starts `job` (jobs already running go on) and answers its generation.
    fn send(&mut self, job: J) -> u64;
    /// The next report of a job that was not cancelled; never blocks.
    fn poll(&mut self) -> Option<Delivery<O>>;
    /// Whether a job that was not cancelled has not yet ended.
    fn busy(&self) -> bool;
    /// The newest running job's progress in 0..=1.
    fn progress(&self) -> Option<f32>;
    /// Cancels every job sent so far: their cancel flags are set and their reports dropped.
    fn cancel(&mut self);
    /// A job (not cancelled) that ended without reporting anything: its thread could not
    /// start or its task panicked (logged). Its owner says so rather than wait for ever.
    fn ended_silently(&mut self) -> Option<u64>;
}

/// What a job's thread tells its worker.
enum Message<O> {
    Output(u64, O),
    Ended(u64),
    /// The job was never run: a newer one superseded it ([`Serial`]).
    Skipped(u64),
}

/// The generations and tickets of the jobs not yet ended, shared by both workers.
struct Ledger {
    sent: u64,
    /// `sent`, as the tickets read it.
    newest: Arc<AtomicU64>,
    /// Reports of jobs of this generation or older are dropped.
    cancelled_through: u64,
    /// The jobs not yet ended, each with whether it has reported anything.
    running: Vec<(Ticket, bool)>,
    /// Jobs that ended without a report, oldest first.
    silent: VecDeque<u64>,
}

impl Ledger {
    fn new() -> Ledger {
        Ledger {
            sent: 0,
            newest: Arc::new(AtomicU64::new(0)),
            cancelled_through: 0,
            running: Vec::new(),
            silent: VecDeque::new(),
        }
    }

    fn start(&mut self) -> Ticket {
        self.sent += 1;
        self.newest.store(self.sent, Ordering::Relaxed);
        let ticket = Ticket::new(self.sent, self.newest.clone());
        self.running.push((ticket.shared(), false));
        ticket
    }

    fn reported(&mut self, generation: u64) {
        for (ticket, reported) in &mut self.running {
            *reported |= ticket.generation == generation;
        }
    }

    fn ended(&mut self, generation: u64) {
        let silent = self.running.iter().any(|(ticket, reported)| ticket.generation == generation && !reported);
        if silent && self.wanted(generation) {
            self.silent.push_back(generation);
        }
        self.running.retain(|(ticket, _)| ticket.generation != generation);
    }

    /// A job that was never run because a newer one made it pointless: it ends, and is not
    /// one that ended silently.
    fn skipped(&mut self, generation: u64) {
        self.running.retain(|(ticket, _)| ticket.generation != generation);
    }

    fn ended_silently(&mut self) -> Option<u64> {
        while let Some(generation) = self.silent.pop_front() {
            if self.wanted(generation) {
                return Some(generation);
            }
        }
        None
    }

    fn wanted(&self, generation: u64) -> bool {
        generation > self.cancelled_through
    }

    fn busy(&self) -> bool {
        self.running.iter().any(|(ticket, _)| self.wanted(ticket.generation))
    }

    fn progress(&self) -> Option<f32> {
        let wanted = self.running.iter().map(|(ticket, _)| ticket).filter(|ticket| self.wanted(ticket.generation));
        let newest = wanted.max_by_key(|ticket| ticket.generation)?;
        Some(newest.progress.load(Ordering::Relaxed) as f32 / 1000.0)
    }

    /// The next report of a wanted job among the messages of a job thread, recording the
    /// ends on the way; never blocks.
    fn next_delivery<O>(&mut self, receiver: &Receiver<Message<O>>) -> Option<Delivery<O>> {
        loop {
            match receiver.try_recv() {
                Ok(Message::Output(generation, output)) if self.wanted(generation) => {
                    self.reported(generation);
                    return Some(Delivery { generation, output });
                }
                Ok(Message::Output(..)) => {}
                Ok(Message::Ended(generation)) => self.ended(generation),
                Ok(Message::Skipped(generation)) => self.skipped(generation),
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return None,
            }
        }
    }

    fn cancel(&mut self) {
        for (ticket, _) in &self.running {
            ticket.cancel.store(true, Ordering::Relaxed);
        }
        self.cancelled_through = self.sent;
    }
}

/// Runs `task` on `job`, catching a panic (logged): the job then just ends.
fn run_guarded<J, O>(name: &str, task: &Task<J, O>, job: J, ticket: &Ticket, report: &Report<'_, O>) {
    let run = || task(job, ticket, report);
    if std::panic::catch_unwind(std::panic::AssertUnwindSafe(run)).is_err() {
        log::error!("the {name} worker's job {} panicked", ticket.generation);
    }
}

/// A [`Worker`] that runs each job on a thread of its own, named after the worker.
pub struct Threaded<J, O> {
    name: String,
    task: Task<J, O>,
    ledger: Ledger,
    sender: Sender<Message<O>>,
    receiver: Receiver<Message<O>>,
}

impl<J: Send + 'static, O: Send + 'static> Threaded<J, O> {
    pub fn new(name: &str, task: Task<J, O>) -> Threaded<J, O> {
        let (sender, receiver) = channel();
        Threaded { name: name.to_string(), task, ledger: Ledger::new(), sender, receiver }
    }
}

impl<J: Send + 'static, O: Send + 'static> Worker<J, O> for Threaded<J, O> {
    fn send(&mut self, job: J) -> u64 {
        let ticket = self.ledger.start();
        let generation = ticket.generation;
        let (task, sender, name) = (self.task.clone(), self.sender.clone(), self.name.clone());
        let spawned = std::thread::Builder::new().name(name.clone()).spawn(move || {
            let report = |output| {
                if !ticket.cancelled() {
                    let _ = sender.send(Message::Output(ticket.generation, output));
                }
            };
            run_guarded(&name, &task, job, &ticket, &report);
            let _ = sender.send(Message::Ended(ticket.generation));
        });
        if let Err(error) = spawned {
            log::error!("cannot start a {} thread: {error}", self.name);
            self.ledger.ended(generation);
        }
        generation
    }

    fn poll(&mut self) -> Option<Delivery<O>> {
        self.ledger.next_delivery(&self.receiver)
    }

    fn busy(&self) -> bool {
        self.ledger.busy()
    }

    fn progress(&self) -> Option<f32> {
        self.ledger.progress()
    }

    fn cancel(&mut self) {
        self.ledger.cancel();
    }

    fn ended_silently(&mut self) -> Option<u64> {
        self.ledger.ended_silently()
    }
}

/// Whether a job waiting to run is made pointless by a newer one sent after it (the newer
/// picture of the same panel): the older is then never run.
pub type Supersedes<J> = Arc<dyn Fn(&J, &J) -> bool + Send + Sync>;

/// A [`Worker`] with one long-lived thread, named after the worker, that runs jobs in the
/// order sent; a job still waiting when a newer one that [`Supersedes`] it arrives is skipped.
/// Where its thread cannot start, jobs run on the caller's thread at the next `poll` (slower,
/// but nothing is lost). Dropped, it lets its thread finish the jobs sent (cancel them first to
/// have them skipped) and waits for it: a process must not exit with the render thread inside
/// the GPU driver.
pub struct Serial<J, O> {
    ledger: Ledger,
    jobs: Option<Sender<(Ticket, J)>>,
    receiver: Receiver<Message<O>>,
    /// Without a thread: the same task, run at `poll`.
    fallback: Option<Inline<J, O>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl<J, O> Drop for Serial<J, O> {
    fn drop(&mut self) {
        self.jobs = None;
        if let Some(thread) = self.thread.take()
            && thread.join().is_err()
        {
            log::error!("a worker thread panicked");
        }
    }
}

impl<J: Send + 'static, O: Send + 'static> Serial<J, O> {
    pub fn new(name: &str, task: Task<J, O>, supersedes: Supersedes<J>) -> Serial<J, O> {
        let (sender, receiver) = channel();
        let (jobs, waiting) = channel::<(Ticket, J)>();
        let thread_name = name.to_string();
        let thread_task = task.clone();
        let spawned = std::thread::Builder::new().name(name.to_string()).spawn(move || {
            while let Ok(first) = waiting.recv() {
                let mut queue = vec![first];
                queue.extend(waiting.try_iter());
                let superseded: Vec<bool> = (0..queue.len())
                    .map(|k| queue[k + 1..].iter().any(|(_, later)| supersedes(&queue[k].1, later)))
                    .collect();
                for ((ticket, job), skip) in queue.into_iter().zip(superseded) {
                    let generation = ticket.generation;
                    if skip || ticket.cancelled() {
                        let _ = sender.send(Message::Skipped(generation));
                        continue;
                    }
                    let report = |output| {
                        if !ticket.cancelled() {
                            let _ = sender.send(Message::Output(generation, output));
                        }
                    };
                    run_guarded(&thread_name, &thread_task, job, &ticket, &report);
                    if sender.send(Message::Ended(generation)).is_err() {
                        return;
                    }
                }
            }
        });
        match spawned {
            Ok(thread) => {
                Serial { ledger: Ledger::new(), jobs: Some(jobs), receiver, fallback: None, thread: Some(thread) }
            }
            Err(error) => {
                log::error!("cannot start the {name} thread, running its jobs on the caller's thread: {error}");
                Serial { ledger: Ledger::new(), jobs: None, receiver, fallback: Some(Inline::new(task)), thread: None }
            }
        }
    }
}

impl<J: Send + 'static, O: Send + 'static> Worker<J, O> for Serial<J, O> {
    fn send(&mut self, job: J) -> u64 {
        if let Some(inline) = self.fallback.as_mut() {
            return inline.send(job);
        }
        let ticket = self.ledger.start();
        let generation = ticket.generation;
        if let Some(jobs) = &self.jobs
            && jobs.send((ticket, job)).is_err()
        {
            log::error!("the worker thread has stopped; job {generation} is not run");
            self.ledger.ended(generation);
        }
        generation
    }

    fn poll(&mut self) -> Option<Delivery<O>> {
        if let Some(inline) = self.fallback.as_mut() {
            return inline.poll();
        }
        self.ledger.next_delivery(&self.receiver)
    }

    fn busy(&self) -> bool {
        self.fallback.as_ref().map_or_else(|| self.ledger.busy(), |inline| inline.busy())
    }

    fn progress(&self) -> Option<f32> {
        self.fallback.as_ref().map_or_else(|| self.ledger.progress(), |inline| inline.progress())
    }

    fn cancel(&mut self) {
        match self.fallback.as_mut() {
            Some(inline) => inline.cancel(),
            None => self.ledger.cancel(),
        }
    }

    fn ended_silently(&mut self) -> Option<u64> {
        match self.fallback.as_mut() {
            Some(inline) => inline.ended_silently(),
            None => self.ledger.ended_silently(),
        }
    }
}

/// A [`Worker`] with no thread: a job sent is run on the caller's thread at the next `poll`
/// (until then it is busy, as a job on a thread would be). For tests.
pub struct Inline<J, O> {
    task: Task<J, O>,
    ledger: Ledger,
    waiting: VecDeque<(Ticket, J)>,
    reports: VecDeque<Delivery<O>>,
}

impl<J, O: Send> Inline<J, O> {
    pub fn new(task: Task<J, O>) -> Inline<J, O> {
        Inline { task, ledger: Ledger::new(), waiting: VecDeque::new(), reports: VecDeque::new() }
    }

    /// Runs the jobs waiting, in the order sent.
    fn run_waiting(&mut self) {
        while let Some((ticket, job)) = self.waiting.pop_front() {
            let generation = ticket.generation;
            let outputs = Mutex::new(Vec::new());
            if self.ledger.wanted(generation) {
                let report = |output| outputs.lock().map(|mut outputs| outputs.push(output)).unwrap_or(());
                run_guarded("inline", &self.task, job, &ticket, &report);
            }
            let outputs = outputs.into_inner().unwrap_or_default();
            if !outputs.is_empty() {
                self.ledger.reported(generation);
            }
            self.ledger.ended(generation);
            self.reports.extend(outputs.into_iter().map(|output| Delivery { generation, output }));
        }
    }
}

impl<J, O: Send> Worker<J, O> for Inline<J, O> {
    fn send(&mut self, job: J) -> u64 {
        let ticket = self.ledger.start();
        let generation = ticket.generation;
        self.waiting.push_back((ticket, job));
        generation
    }

    fn poll(&mut self) -> Option<Delivery<O>> {
        self.run_waiting();
        while let Some(report) = self.reports.pop_front() {
            if self.ledger.wanted(report.generation) {
                return Some(report);
            }
        }
        None
    }

    fn busy(&self) -> bool {
        self.ledger.busy()
    }

    fn progress(&self) -> Option<f32> {
        self.ledger.progress()
    }

    fn cancel(&mut self) {
        self.ledger.cancel();
    }

    fn ended_silently(&mut self) -> Option<u64> {
        self.run_waiting();
        self.ledger.ended_silently()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// Doubles its job, then (for an odd job) reports it again plus one.
    fn doubling() -> Task<u32, u32> {
        Arc::new(|job: u32, ticket: &Ticket, report: &Report<'_, u32>| {
            ticket.set_progress(0.5);
            report(job * 2);
            if job % 2 == 1 {
                report(job * 2 + 1);
            }
        })
    }

    #[test]
    fn a_serial_worker_runs_jobs_in_order_on_one_thread_and_skips_superseded_ones() {
        let gate = Arc::new(Mutex::new(()));
        let held = gate.lock().unwrap();
        let waiting_on = gate.clone();
        // Each job waits for the gate, so the later ones queue up behind the first.
        let task: Task<u32, (u32, String)> = Arc::new(move |job, _: &Ticket, report| {
            drop(waiting_on.lock());
            report((job, std::thread::current().name().unwrap_or_default().to_string()));
        });
        // Jobs of the same tens supersede each other (the same panel).
        let supersedes: Supersedes<u32> = Arc::new(|older, newer| older / 10 == newer / 10);
        let mut worker = Serial::new("serial-test", task, supersedes);
        for job in [1, 11, 12, 13, 21] {
            worker.send(job);
        }
        assert!(worker.busy());
        drop(held);
        let mut reports = Vec::new();
        for _ in 0..2000 {
            while let Some(delivery) = worker.poll() {
                reports.push(delivery.output);
            }
            if !worker.busy() {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        let jobs: Vec<u32> = reports.iter().map(|(job, _)| *job).collect();
        // The first was already running; of the queued 11, 12, 13 only the newest runs.
        assert_eq!(jobs.first(), Some(&1));
        assert!(jobs.contains(&13) && jobs.contains(&21) && !jobs.contains(&11), "{jobs:?}");
        assert!(reports.iter().all(|(_, thread)| thread == "serial-test"));
        assert_eq!(worker.ended_silently(), None, "a skipped job did not end silently");
    }

    fn drain(worker: &mut dyn Worker<u32, u32>) -> Vec<Delivery<u32>> {
        let mut reports = Vec::new();
        for _ in 0..2000 {
            while let Some(report) = worker.poll() {
                reports.push(report);
            }
            if !worker.busy() {
                return reports;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        panic!("the worker stayed busy for two seconds");
    }

    fn both() -> [Box<dyn Worker<u32, u32>>; 2] {
        [Box::new(Threaded::new("test", doubling())), Box::new(Inline::new(doubling()))]
    }

    #[test]
    fn every_report_of_a_job_comes_back_with_its_generation_and_then_it_is_idle() {
        for mut worker in both() {
            assert!(!worker.busy());
            assert_eq!(worker.send(3), 1);
            assert!(worker.busy(), "a job sent is busy until it ends");
            let reports = drain(worker.as_mut());
            assert_eq!(reports, vec![Delivery { generation: 1, output: 6 }, Delivery { generation: 1, output: 7 }]);
            assert!(!worker.busy());
            assert_eq!(worker.progress(), None);
        }
    }

    #[test]
    fn a_cancelled_job_is_never_reported_and_the_next_one_is() {
        for mut worker in both() {
            worker.send(5);
            worker.cancel();
            assert!(!worker.busy(), "a cancelled job does not keep the worker busy");
            assert_eq!(worker.send(2), 2);
            let reports = drain(worker.as_mut());
            assert_eq!(reports, vec![Delivery { generation: 2, output: 4 }]);
        }
    }

    #[test]
    fn a_job_sees_its_cancel_flag() {
        let (seen_sender, seen) = channel();
        let task: Task<(), ()> = Arc::new(move |_, ticket: &Ticket, _: &Report<'_, ()>| {
            while !ticket.cancelled() {
                std::thread::sleep(Duration::from_millis(1));
            }
            let _ = seen_sender.send(ticket.generation());
        });
        let mut worker = Threaded::new("test", task);
        worker.send(());
        worker.cancel();
        assert_eq!(seen.recv_timeout(Duration::from_secs(5)), Ok(1));
    }

    #[test]
    fn a_panicking_job_ends_without_taking_the_worker_down() {
        let task: Task<u32, u32> = Arc::new(|job: u32, _: &Ticket, report: &Report<'_, u32>| {
            assert!(job != 0, "a job of 0 panics");
            report(job);
        });
        for mut worker in [
            Box::new(Threaded::new("test", task.clone())) as Box<dyn Worker<u32, u32>>,
            Box::new(Inline::new(task.clone())),
        ] {
            worker.send(0);
            assert!(drain(worker.as_mut()).is_empty());
            assert_eq!(worker.ended_silently(), Some(1), "the owner hears that the job ended without a word");
            assert_eq!(worker.ended_silently(), None);
            worker.send(9);
            assert_eq!(drain(worker.as_mut()), vec![Delivery { generation: 2, output: 9 }]);
        }
    }

    #[test]
    fn the_inline_worker_runs_nothing_until_polled_and_starts_no_thread() {
        let calls = Arc::new(AtomicU32::new(0));
        let counted = calls.clone();
        let caller = std::thread::current().id();
        let task: Task<u32, u32> = Arc::new(move |job: u32, _: &Ticket, report: &Report<'_, u32>| {
            assert_eq!(std::thread::current().id(), caller, "inline jobs run on the caller's thread");
            counted.fetch_add(1, Ordering::Relaxed);
            report(job);
        });
        let mut worker = Inline::new(task);
        worker.send(1);
        worker.send(2);
        assert_eq!(calls.load(Ordering::Relaxed), 0);
        assert_eq!(worker.poll().map(|r| r.output), Some(1));
        assert_eq!(calls.load(Ordering::Relaxed), 2);
        assert_eq!(worker.poll().map(|r| r.output), Some(2));
        assert!(worker.poll().is_none());
    }
}
