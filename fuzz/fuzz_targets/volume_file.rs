//! Whole files through `volume::open`, as each format: header and data together, so the readers'
//! offset and length checks (the part that guards the memory map) are exercised too. The first
//! byte picks the file name the open sees.
#![no_main]
use libfuzzer_sys::fuzz_target;

const NAMES: [&str; 6] = ["f.nrrd", "f.nii", "f.mha", "f.nii.gz", "f_4x4x4_uint16.raw", "f.dcm"];

fuzz_target!(|data: &[u8]| {
    let Some((&selector, contents)) = data.split_first() else { return };
    let Ok(folder) = tempfile_folder() else { return };
    let path = folder.join(NAMES[selector as usize % NAMES.len()]);
    if std::fs::write(&path, contents).is_err() {
        return;
    }
    let options = volasso::volume::OpenOptions { cache_dir: Some(folder.join("cache")), ..Default::default() };
    if let Ok(volume) = volasso::volume::open(&path, &options) {
        // Everything a reader accepted must be readable end to end.
        let mut values = vec![0f32; volume.voxel_count().min(1 << 16)];
        volume.read_f32(0, &mut values);
        let _ = volume.value(volume.voxel_count() - 1);
    }
    let _ = std::fs::remove_file(&path);
});

fn tempfile_folder() -> std::io::Result<std::path::PathBuf> {
    let folder = std::env::temp_dir().join(format!("volasso-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&folder)?;
    Ok(folder)
}
