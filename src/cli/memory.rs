//! Resident memory of this process, from /proc (Linux): anonymous pages (copies in RAM) apart
//! from file-backed ones (pages of memory-mapped files that were read).

/// Resident memory in bytes, split by kind; `None` where /proc is not available.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ResidentMemory {
    pub anonymous_bytes: u64,
    pub file_backed_bytes: u64,
    pub peak_bytes: u64,
}

pub fn resident_memory() -> Option<ResidentMemory> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| -> Option<u64> {
        let line = status.lines().find(|l| l.starts_with(name))?;
        let kib: u64 = line[name.len()..].trim().trim_end_matches("kB").trim().parse().ok()?;
        Some(kib * 1024)
    };
    Some(ResidentMemory {
        anonymous_bytes: field("RssAnon:")?,
        file_backed_bytes: field("RssFile:")?,
        peak_bytes: field("VmHWM:")?,
    })
}
