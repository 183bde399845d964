//! How much memory the kiosk lets one volume's decoding take: [`kiosk_memory_ceiling`], from the
//! machine's RAM (`/proc/meminfo`) and the limits of the kiosk's cgroup and its parents
//! (`memory.max`, `memory.high` of cgroup v2; the appliance's `volasso.service` sets both).
//!
//! Why a third of the smallest: a compressed volume is decoded whole into memory before it is
//! cached and mapped, and once open the work screen holds its labels (one byte a voxel) and the
//! 3-D view's texture (two bytes a voxel), so about 2.5 times the decoded size must fit beside
//! the UI. On a 4 GB panel with `MemoryHigh=2560M` that is 853 MiB: a 512 x 512 x 1600 CT.
//!
//! Never: allocates or limits anything itself; the readers' options take the figure.

use std::path::Path;

/// The share of the memory budget one volume's decoded bytes may take.
pub const BUDGET_SHARE: u64 = 3;

/// The largest number of bytes a volume may decode to in this kiosk; `None` when neither the
/// machine's memory nor a cgroup limit can be read (no `/proc`).
pub fn kiosk_memory_ceiling() -> Option<u64> {
    memory_ceiling_under(Path::new("/"))
}

/// [`kiosk_memory_ceiling`] with `/proc` and `/sys/fs/cgroup` under `root` (tests).
pub fn memory_ceiling_under(root: &Path) -> Option<u64> {
    let total = std::fs::read_to_string(root.join("proc/meminfo")).ok().and_then(|text| mem_total(&text));
    let cgroup = std::fs::read_to_string(root.join("proc/self/cgroup")).ok();
    let limits = cgroup
        .as_deref()
        .and_then(cgroup_v2_path)
        .map_or_else(Vec::new, |path| cgroup_limits(&root.join("sys/fs/cgroup"), path));
    let budget = total.into_iter().chain(limits).min()?;
    Some(budget / BUDGET_SHARE)
}

/// `MemTotal` of `/proc/meminfo`, in bytes.
fn mem_total(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|line| line.starts_with("MemTotal:"))?;
    let kib: u64 = line["MemTotal:".len()..].trim().strip_suffix("kB")?.trim().parse().ok()?;
    kib.checked_mul(1024)
}

/// The process's cgroup v2 path from `/proc/self/cgroup` (the `0::/PATH` line).
fn cgroup_v2_path(cgroup: &str) -> Option<&str> {
    cgroup.lines().find_map(|line| line.strip_prefix("0::")).map(|path| path.trim_start_matches('/'))
}

/// The `memory.max` and `memory.high` limits of the cgroup at `path` under `mount` and of every
/// parent ("max", or a file that is not there, is no limit).
fn cgroup_limits(mount: &Path, path: &str) -> Vec<u64> {
    let mut limits = Vec::new();
    let mut folder = mount.join(path);
    loop {
        for name in ["memory.max", "memory.high"] {
            if let Some(limit) = std::fs::read_to_string(folder.join(name)).ok().and_then(|text| limit(&text)) {
                limits.push(limit);
            }
        }
        if folder == mount || !folder.pop() || !folder.starts_with(mount) {
            return limits;
        }
    }
}

fn limit(text: &str) -> Option<u64> {
    text.trim().parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    const MEMINFO: &str = "MemTotal:        3906250 kB\nMemFree:         1000000 kB\n";

    fn machine(cgroup_line: &str, limits: &[(&str, &str, &str)]) -> tempfile::TempDir {
        let root = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(root.path().join("proc/self")).unwrap();
        std::fs::write(root.path().join("proc/meminfo"), MEMINFO).unwrap();
        std::fs::write(root.path().join("proc/self/cgroup"), cgroup_line).unwrap();
        for (folder, file, value) in limits {
            let folder = root.path().join("sys/fs/cgroup").join(folder);
            std::fs::create_dir_all(&folder).unwrap();
            std::fs::write(folder.join(file), value).unwrap();
        }
        root
    }

    #[test]
    fn the_ceiling_is_a_third_of_the_smallest_of_ram_and_every_cgroup_limit() {
        // The appliance: a 4 GB panel, MemoryHigh=2560M and MemoryMax=3G on the service.
        let service = "system.slice/volasso.service";
        let root = machine(
            "0::/system.slice/volasso.service\n",
            &[
                (service, "memory.max", "3221225472\n"),
                (service, "memory.high", "2684354560\n"),
                ("system.slice", "memory.max", "max\n"),
            ],
        );
        assert_eq!(memory_ceiling_under(root.path()), Some(2_684_354_560 / 3));
        // A parent's lower limit counts too.
        std::fs::write(root.path().join("sys/fs/cgroup/system.slice/memory.max"), "1073741824").unwrap();
        assert_eq!(memory_ceiling_under(root.path()), Some(1_073_741_824 / 3));
    }

    #[test]
    fn without_limits_the_ram_decides_and_without_proc_nothing_does() {
        let root = machine("0::/user.slice/session-1.scope\n", &[("user.slice", "memory.max", "max")]);
        assert_eq!(memory_ceiling_under(root.path()), Some(3_906_250 * 1024 / 3));
        // cgroup v1 lines carry no `0::` entry: only the RAM counts.
        let v1 = machine("4:memory:/user.slice\n", &[]);
        assert_eq!(memory_ceiling_under(v1.path()), Some(3_906_250 * 1024 / 3));
        let empty = tempfile::tempdir().unwrap();
        assert_eq!(memory_ceiling_under(empty.path()), None);
        assert_eq!(mem_total("MemTotal: lots\n"), None);
        assert_eq!(limit("max\n"), None);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn this_machine_has_a_ceiling() {
        let ceiling = kiosk_memory_ceiling().expect("/proc/meminfo is readable on Linux");
        assert!(ceiling > 16 << 20, "{ceiling}");
    }
}
