//! A short fuzz pass that CI can afford without cargo-fuzz's instrumented build (`.ci/fuzz`
//! runs the long one): every seed under `fuzz/seeds` and the shared DICOM slice, and a few
//! thousand seeded random mutations of them (bit flips, truncations, length fields overwritten
//! with extremes, numbers in text headers replaced by extremes, splices), through every reader
//! entry point: headers, whole files, DICOM files, raw names, `volume::open`. None may panic,
//! none may ask the allocator for more than the decoding ceiling, and live memory stays
//! within a few ceilings.
//!
//! Allocation is counted by this binary's global allocator ([`Counting`]). So that no other
//! test's memory is counted, [`short_fuzz_pass`] re-runs this test binary with only
//! [`mutations_in_a_process_of_their_own`], which does the work.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use volasso::volume::limits::ReadLimits;
use volasso::volume::{OpenOptions, Volume, dicom, metaimage, nifti, nrrd, raw};

/// Counts live bytes, their peak, and the largest single request.
struct Counting;

static LIVE_BYTES: AtomicUsize = AtomicUsize::new(0);
static PEAK_BYTES: AtomicUsize = AtomicUsize::new(0);
static LARGEST_REQUEST: AtomicUsize = AtomicUsize::new(0);

fn allocated(bytes: usize) {
    let live = LIVE_BYTES.fetch_add(bytes, Ordering::Relaxed) + bytes;
    PEAK_BYTES.fetch_max(live, Ordering::Relaxed);
}

// SAFETY: every call forwards to the system allocator unchanged; the counters only observe.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST_REQUEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: the caller's layout, passed on.
        let pointer = unsafe { System.alloc(layout) };
        if !pointer.is_null() {
            allocated(layout.size());
        }
        pointer
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        LARGEST_REQUEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: the caller's layout, passed on.
        let pointer = unsafe { System.alloc_zeroed(layout) };
        if !pointer.is_null() {
            allocated(layout.size());
        }
        pointer
    }

    unsafe fn dealloc(&self, pointer: *mut u8, layout: Layout) {
        // SAFETY: the caller's pointer and layout, passed on.
        unsafe { System.dealloc(pointer, layout) };
        LIVE_BYTES.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, pointer: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST_REQUEST.fetch_max(new_size, Ordering::Relaxed);
        // SAFETY: the caller's pointer, layout and size, passed on.
        let moved = unsafe { System.realloc(pointer, layout, new_size) };
        if !moved.is_null() {
            LIVE_BYTES.fetch_sub(layout.size(), Ordering::Relaxed);
            allocated(new_size);
        }
        moved
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The decoding ceiling of the pass.
const CEILING_BYTES: u64 = 16 << 20;
const LIMITS: ReadLimits = ReadLimits { max_decoded_bytes: CEILING_BYTES, allow_external_data: false };
/// Mutations of each seed.
const MUTATIONS_PER_SEED: usize = 150;

/// SplitMix64: a seeded generator, enough for mutations.
struct Random(u64);

impl Random {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, bound: usize) -> usize {
        (self.next() % bound.max(1) as u64) as usize
    }
}

/// One to three random edits of `seed`.
fn mutate(seed: &[u8], random: &mut Random) -> Vec<u8> {
    const EXTREME_WORDS: [u32; 6] = [0xFFFF_FFFF, 0xFFFF_FFF0, 0x7FFF_FFFF, 0x8000_0000, 0, 0x0001_0000];
    const EXTREME_NUMBERS: [&str; 7] = ["18446744073709551615", "-1", "99999999999", "0", "nan", "1e308", "-32768"];
    let mut bytes = seed.to_vec();
    for _ in 0..1 + random.below(3) {
        let at = random.below(bytes.len());
        match random.below(6) {
            0 => {
                for _ in 0..1 + random.below(8) {
                    let bit = random.below(bytes.len() * 8);
                    if let Some(byte) = bytes.get_mut(bit / 8) {
                        *byte ^= 1 << (bit % 8);
                    }
                }
            }
            1 => bytes.truncate(at),
            2 => {
                let word = match random.below(7) {
                    6 => random.next() as u32,
                    pick => EXTREME_WORDS[pick],
                };
                let raw = if random.below(2) == 0 { word.to_le_bytes() } else { word.to_be_bytes() };
                let width = if random.below(3) == 0 { 2 } else { 4 };
                for (offset, value) in raw.iter().take(width).enumerate() {
                    if let Some(byte) = bytes.get_mut(at + offset) {
                        *byte = *value;
                    }
                }
            }
            3 => {
                // A run of digits (a size, a skip, a spacing in a text header) becomes an extreme.
                if let Some(start) = (at..bytes.len()).find(|&i| bytes[i].is_ascii_digit()) {
                    let end = (start..bytes.len()).find(|&i| !bytes[i].is_ascii_digit()).unwrap_or(bytes.len());
                    let number = EXTREME_NUMBERS[random.below(EXTREME_NUMBERS.len())];
                    bytes.splice(start..end, number.bytes());
                }
            }
            4 => {
                let end = (at + 1 + random.below(16)).min(bytes.len());
                bytes.drain(at..end);
            }
            _ => {
                let from = random.below(bytes.len());
                let chunk: Vec<u8> = bytes[from..(from + 1 + random.below(64)).min(bytes.len())].to_vec();
                bytes.splice(at..at, chunk);
            }
        }
        if bytes.is_empty() {
            break;
        }
    }
    bytes
}

/// Reads what a reader accepted, end to end.
fn read_all(volume: &Volume) {
    let count = volume.voxel_count();
    let mut values = vec![0f32; count.min(1 << 12)];
    volume.read_f32(0, &mut values);
    volume.read_f32(count - values.len(), &mut values);
    let _ = volume.value(count - 1);
}

/// Feeds `bytes` (an input of the fuzz target `kind`) to its reader entry points.
fn feed(kind: &str, bytes: &[u8], folder: &Path) {
    let write = |name: &str, contents: &[u8]| {
        let path = folder.join(name);
        std::fs::write(&path, contents).unwrap();
        path
    };
    let text = String::from_utf8_lossy(bytes);
    match kind {
        "nrrd_header" | "nrrd_file" => {
            let _ = nrrd::parse_header(bytes, Path::new("m.nrrd"));
            if let Ok(read) = nrrd::read_with(&write("m.nrrd", bytes), &LIMITS) {
                read_all(&read.volume);
            }
        }
        "metaimage_header" | "metaimage_file" => {
            let _ = metaimage::parse_header(bytes, Path::new("m.mha"));
            if let Ok(read) = metaimage::read_with(&write("m.mha", bytes), &LIMITS) {
                read_all(&read.volume);
            }
        }
        "nifti_header" | "nifti_file" => {
            let contents = if kind == "nifti_file" { bytes.get(1..).unwrap_or_default() } else { bytes };
            let _ = nifti::parse_header(contents, Path::new("m.nii"));
            for name in ["m.nii", "m.nii.gz"] {
                if let Ok(read) = nifti::read_with(&write(name, contents), &LIMITS) {
                    read_all(&read.volume);
                }
            }
        }
        "dicom_file" => {
            let path = write("m.dcm", bytes);
            if let Ok(source) = dicom::list_source(&path, &LIMITS)
                && let Ok(import) = dicom::read_source(&path, &source, &dicom::DicomOptions::default(), &LIMITS)
            {
                read_all(&import.volume);
            }
        }
        "raw_name" => {
            if let Some(naming) = raw::parse_name(&text) {
                let _ = volasso::volume::checked_voxel_count(naming.dims, naming.voxel_type, Path::new("m"));
            }
        }
        "volume_file" => {
            const NAMES: [&str; 7] = ["m.nrrd", "m.nii", "m.mha", "m.nii.gz", "m_4x4x4_uint16.raw", "m.dcm", "m.nhdr"];
            let Some((&selector, contents)) = bytes.split_first() else { return };
            let path = write(NAMES[selector as usize % NAMES.len()], contents);
            let cache = folder.join("cache");
            let options = OpenOptions {
                cache_dir: Some(cache.clone()),
                max_decoded_bytes: Some(CEILING_BYTES),
                ..OpenOptions::default()
            };
            if let Ok(volume) = volasso::volume::open(&path, &options) {
                read_all(&volume);
            }
            let _ = std::fs::remove_file(&path);
            let _ = std::fs::remove_dir_all(&cache);
        }
        _ => {}
    }
}

/// Every seed, as (fuzz target, bytes): `fuzz/seeds/<target>/*` and the shared CT slice.
fn seeds() -> Vec<(String, Vec<u8>)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut seeds = Vec::new();
    let mut targets: Vec<PathBuf> =
        std::fs::read_dir(root.join("fuzz/seeds")).unwrap().map(|entry| entry.unwrap().path()).collect();
    targets.sort();
    for target in targets {
        let kind = target.file_name().unwrap().to_string_lossy().into_owned();
        let mut files: Vec<PathBuf> = std::fs::read_dir(&target).unwrap().map(|entry| entry.unwrap().path()).collect();
        files.sort();
        seeds.extend(files.into_iter().map(|file| (kind.clone(), std::fs::read(file).unwrap())));
    }
    seeds.push(("dicom_file".into(), std::fs::read(crate::support::data("dicom/ct_small.dcm")).unwrap()));
    seeds
}

#[test]
#[ignore = "the short fuzz pass runs it in a process of its own"]
fn mutations_in_a_process_of_their_own() {
    let folder = tempfile::tempdir().unwrap();
    let seeds = seeds();
    let baseline = LIVE_BYTES.load(Ordering::Relaxed);
    LARGEST_REQUEST.store(0, Ordering::Relaxed);
    PEAK_BYTES.store(baseline, Ordering::Relaxed);
    let started = std::time::Instant::now();
    let mut random = Random(0x766F_6C61_7373_6F21);
    let mut inputs = 0usize;
    for (kind, seed) in &seeds {
        feed(kind, seed, folder.path());
        inputs += 1;
        if seed.is_empty() {
            continue;
        }
        for _ in 0..MUTATIONS_PER_SEED {
            feed(kind, &mutate(seed, &mut random), folder.path());
            inputs += 1;
        }
    }
    let largest = LARGEST_REQUEST.load(Ordering::Relaxed) as u64;
    let peak = (PEAK_BYTES.load(Ordering::Relaxed) - baseline) as u64;
    println!(
        "short fuzz pass: {inputs} inputs from {} seeds in {:.1} s; largest allocation {} KiB, peak live {} KiB above the start",
        seeds.len(),
        started.elapsed().as_secs_f64(),
        largest >> 10,
        peak >> 10
    );
    assert!(inputs > 3000, "{inputs} inputs");
    assert!(largest <= CEILING_BYTES, "an allocation of {largest} bytes, above the {CEILING_BYTES}-byte ceiling");
    assert!(peak <= 3 * CEILING_BYTES, "peak live memory {peak} bytes");
}

#[test]
fn short_fuzz_pass() {
    let output = std::process::Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "mutations::mutations_in_a_process_of_their_own", "--ignored", "--nocapture"])
        .args(["--test-threads", "1"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "the mutations failed:\n{stdout}\n{stderr}");
    assert!(stdout.contains("1 passed"), "the mutations did not run:\n{stdout}");
    let summary = stdout.lines().find_map(|line| line.find("short fuzz pass").map(|at| &line[at..]));
    println!("{}", summary.unwrap_or_default());
}
