//! `volasso record [--device PATH] --out FILE [--seconds N]`: records a touchscreen's raw events
//! as `volasso-events/1`, for replay through the same tracker the kiosk uses.
//!
//! Times in the file count from the start of the recording. The file is written atomically
//! when the time is up (or the device fails, keeping what was read); nothing is written if no
//! device can be opened.
//!
//! Never: interprets the events.

use super::CliError;
use super::args::RecordArgs;

/// Events kept at most (the format's limit); recording stops early at it.
const MAX_RECORDED_EVENTS: usize = crate::touch::format::MAX_EVENTS;

#[cfg(target_os = "linux")]
pub fn run(args: &RecordArgs) -> Result<(), CliError> {
    use crate::touch::device::TouchDevice;
    use crate::touch::format::{self, Recording};
    use std::time::{Duration, Instant, SystemTime};

    let inputs: Vec<(&'static str, &std::path::Path)> =
        args.device.iter().map(|device| ("input device (--device)", device.as_path())).collect();
    super::outputs::check(&inputs, &[("recording (--out)", &args.out)])?;
    let device = match &args.device {
        Some(path) => TouchDevice::open(path)?,
        None => TouchDevice::open_first()?,
    };
    let info = device.info().clone();
    log::info!("recording '{}' from {} for {} s", info.name, device.path().display(), args.seconds);
    let origin_us = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.as_micros() as u64);
    let (sender, receiver) = std::sync::mpsc::channel();
    // The reader thread blocks in read(); it is left to end with the process.
    let reader = device.spawn_reader(sender)?;
    let deadline = Instant::now() + Duration::from_secs_f64(args.seconds);
    let mut events = Vec::new();
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        match receiver.recv_timeout(left) {
            Ok(mut event) => {
                event.time_us = event.time_us.saturating_sub(origin_us);
                events.push(event);
                if events.len() >= MAX_RECORDED_EVENTS {
                    log::warn!("stopped early at {MAX_RECORDED_EVENTS} events");
                    break;
                }
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => break,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                // The device failed (unplugged): keep what was recorded, say why.
                if let Ok(Err(error)) = reader.join() {
                    log::warn!("recording ended early: {error}");
                }
                break;
            }
        }
    }
    let text = format::write(&Recording { device: info, events });
    crate::atomic_file::write_atomically(&args.out, |writer| std::io::Write::write_all(writer, text.as_bytes()))
        .map_err(|source| CliError::Output { source, path: args.out.clone() })?;
    println!("{}", args.out.display());
    Ok(())
}

#[cfg(not(target_os = "linux"))]
pub fn run(_args: &RecordArgs) -> Result<(), CliError> {
    Err(CliError::NoEvdev)
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    #[test]
    fn without_a_device_nothing_is_written_and_the_error_says_why() {
        let folder = tempfile::tempdir().unwrap();
        let out = folder.path().join("touch.events");
        let missing = folder.path().join("event99");
        let args = RecordArgs { device: Some(missing.clone()), out: out.clone(), seconds: 0.1 };
        let error = run(&args).unwrap_err();
        assert!(error.to_string().contains(&missing.display().to_string()), "{error}");
        assert!(!out.exists());
    }
}
