//! Every volume of `../shared/data` opens with the right geometry and values. Expected sums and
//! probe values were computed independently with numpy from the raw bytes.

use crate::support::data;
use volasso::volume::{OpenOptions, VoxelType, open};

struct Expected {
    name: &'static str,
    dims: [usize; 3],
    voxel_type: VoxelType,
    spacing_mm: [f64; 3],
    range: (f64, f64),
    sum: f64,
    /// The value of voxel `voxel_count / 2 + 17`.
    probe: f64,
}

const EXPECTED: &[Expected] = &[
    Expected {
        name: "tooth.nrrd",
        dims: [103, 94, 161],
        voxel_type: VoxelType::U8,
        spacing_mm: [1.0; 3],
        range: (0.0, 255.0),
        sum: 160814065.0,
        probe: 163.0,
    },
    Expected {
        name: "frog.nrrd",
        dims: [256, 256, 44],
        voxel_type: VoxelType::U8,
        spacing_mm: [1.0; 3],
        range: (0.0, 255.0),
        sum: 39364450.0,
        probe: 1.0,
    },
    Expected {
        name: "anatomical.nii",
        dims: [33, 41, 25],
        voxel_type: VoxelType::I16,
        spacing_mm: [2.0; 3],
        range: (-610.0, 30393.0),
        sum: 284166082.0,
        probe: 9484.0,
    },
    Expected {
        name: "engine_256x256x256_uint8.raw",
        dims: [256, 256, 256],
        voxel_type: VoxelType::U8,
        spacing_mm: [1.0; 3],
        range: (0.0, 255.0),
        sum: 187475047.0,
        probe: 0.0,
    },
    Expected {
        name: "lobster_301x324x56_uint8.raw",
        dims: [301, 324, 56],
        voxel_type: VoxelType::U8,
        spacing_mm: [1.0; 3],
        range: (0.0, 255.0),
        sum: 71284695.0,
        probe: 0.0,
    },
    Expected {
        name: "vismale_128x256x256_uint8.raw",
        dims: [128, 256, 256],
        voxel_type: VoxelType::U8,
        spacing_mm: [1.0; 3],
        range: (1.0, 254.0),
        sum: 295695496.0,
        probe: 1.0,
    },
    // The data README says -1024..3033; the file's bytes (numpy) span -1024..2986.
    Expected {
        name: "cranium_ct_256x256x108_int16.raw",
        dims: [256, 256, 108],
        voxel_type: VoxelType::I16,
        spacing_mm: [1.0; 3],
        range: (-1024.0, 2986.0),
        sum: -4147325847.0,
        probe: -1001.0,
    },
];

#[test]
fn shared_volumes_open_with_known_geometry_and_values() {
    for expected in EXPECTED {
        let volume =
            open(&data(expected.name), &OpenOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", expected.name));
        assert_eq!(volume.dims, expected.dims, "{}", expected.name);
        assert_eq!(volume.voxel_type, expected.voxel_type, "{}", expected.name);
        assert_eq!(volume.spacing_mm, expected.spacing_mm, "{}", expected.name);
        let range = volume.value_range();
        assert_eq!((range.min, range.max), expected.range, "{}", expected.name);
        let mut values = vec![0f32; volume.voxel_count()];
        volume.read_f32(0, &mut values);
        let sum: f64 = values.iter().map(|&v| v as f64).sum();
        assert_eq!(sum, expected.sum, "{}", expected.name);
        assert_eq!(volume.value(volume.voxel_count() / 2 + 17), expected.probe, "{}", expected.name);
        assert!(volume.is_memory_mapped(), "{} was copied into memory", expected.name);
    }
}

#[test]
fn explicit_spacing_overrides_the_raw_default() {
    let options = OpenOptions { spacing_mm: Some([1.578, 0.996, 1.008]), ..OpenOptions::default() };
    let volume = open(&data("vismale_128x256x256_uint8.raw"), &options).unwrap();
    assert_eq!(volume.spacing_mm, [1.578, 0.996, 1.008]);
}

#[test]
fn explicit_dims_and_type_read_any_raw_file() {
    // The lobster read as 301 x 324 x 28 int16 is the same bytes, reinterpreted.
    let options =
        OpenOptions { dims: Some([301, 324, 28]), voxel_type: Some(VoxelType::I16), ..OpenOptions::default() };
    let volume = open(&data("lobster_301x324x56_uint8.raw"), &options).unwrap();
    assert_eq!(volume.dims, [301, 324, 28]);
    assert_eq!(volume.voxel_type, VoxelType::I16);
}

#[test]
fn gzip_nrrd_is_imported_once_into_the_cache_and_mapped_from_there() {
    let folder = tempfile::tempdir().unwrap();
    let cache = folder.path().join("cache");
    // Re-encode tooth.nrrd as gzip.
    let source = open(&data("tooth.nrrd"), &OpenOptions::default()).unwrap();
    let mut compressed = Vec::new();
    {
        use std::io::Write;
        let mut encoder = flate2::write::GzEncoder::new(&mut compressed, flate2::Compression::fast());
        encoder.write_all(source.raw_bytes()).unwrap();
        encoder.finish().unwrap();
    }
    let path = folder.path().join("tooth-gz.nrrd");
    let mut file =
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 103 94 161\nspacings: 1 1 1\nencoding: gzip\n\n".to_vec();
    file.extend(compressed);
    std::fs::write(&path, file).unwrap();

    let options = OpenOptions { cache_dir: Some(cache.clone()), ..OpenOptions::default() };
    let first = open(&path, &options).unwrap();
    assert!(first.is_memory_mapped(), "the imported volume is mapped from the cache file");
    assert_eq!(first.raw_bytes(), source.raw_bytes());
    assert_eq!(first.source, path);
    let entries: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "nrrd"))
        .collect();
    assert_eq!(entries.len(), 1, "one cache entry");
    let entry = entries[0].clone();
    let stamp = std::fs::metadata(&entry).unwrap().modified().unwrap();

    let second = open(&path, &options).unwrap();
    assert_eq!(second.raw_bytes(), source.raw_bytes());
    assert_eq!(std::fs::metadata(&entry).unwrap().modified().unwrap(), stamp, "the entry was reused, not rewritten");

    // A damaged entry is rebuilt, not trusted.
    std::fs::write(&entry, b"NRRD0004\ntype: uint8\n").unwrap();
    let third = open(&path, &options).unwrap();
    assert_eq!(third.raw_bytes(), source.raw_bytes());
}

#[test]
fn detached_header_metaimage_and_nifti_pairs_read_the_same_voxels() {
    let folder = tempfile::tempdir().unwrap();
    let source = open(&data("anatomical.nii"), &OpenOptions::default()).unwrap();
    let bytes = source.raw_bytes(); // big-endian int16
    std::fs::write(folder.path().join("data.raw"), bytes).unwrap();
    std::fs::write(
        folder.path().join("v.nhdr"),
        "NRRD0004\ntype: int16\ndimension: 3\nsizes: 33 41 25\nspacings: 2 2 2\nendian: big\nencoding: raw\ndata file: data.raw\n",
    )
    .unwrap();
    std::fs::write(
        folder.path().join("v.mhd"),
        "ObjectType = Image\nNDims = 3\nDimSize = 33 41 25\nElementSpacing = 2 2 2\nElementType = MET_SHORT\nBinaryDataByteOrderMSB = True\nElementDataFile = data.raw\n",
    )
    .unwrap();
    let mut mha = b"ObjectType = Image\nNDims = 3\nDimSize = 33 41 25\nElementSpacing = 2 2 2\nElementType = MET_SHORT\nElementByteOrderMSB = True\nElementDataFile = LOCAL\n".to_vec();
    mha.extend_from_slice(bytes);
    std::fs::write(folder.path().join("v.mha"), mha).unwrap();
    for name in ["v.nhdr", "v.mhd", "v.mha"] {
        let volume = open(&folder.path().join(name), &OpenOptions::default()).unwrap();
        assert_eq!(volume.dims, [33, 41, 25], "{name}");
        assert_eq!(volume.spacing_mm, [2.0; 3], "{name}");
        for index in [0, 1000, 33824] {
            assert_eq!(volume.value(index), source.value(index), "{name} voxel {index}");
        }
        assert!(volume.is_memory_mapped(), "{name}");
    }
}

#[test]
fn nifti_scaling_is_applied_and_gzip_nifti_is_cached() {
    let folder = tempfile::tempdir().unwrap();
    let mut bytes = std::fs::read(data("anatomical.nii")).unwrap();
    // scl_slope = 2, scl_inter = -10 (big-endian header).
    bytes[112..116].copy_from_slice(&2f32.to_be_bytes());
    bytes[116..120].copy_from_slice(&(-10f32).to_be_bytes());
    let scaled = folder.path().join("scaled.nii");
    std::fs::write(&scaled, &bytes).unwrap();
    let volume = open(&scaled, &OpenOptions::default()).unwrap();
    assert_eq!(volume.value_range().min, -610.0 * 2.0 - 10.0);
    assert_eq!(volume.value_range().max, 30393.0 * 2.0 - 10.0);

    let gz = folder.path().join("scaled.nii.gz");
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut encoder, &bytes).unwrap();
    std::fs::write(&gz, encoder.finish().unwrap()).unwrap();
    let options = OpenOptions { cache_dir: Some(folder.path().join("cache")), ..OpenOptions::default() };
    let cached = open(&gz, &options).unwrap();
    assert!(cached.is_memory_mapped());
    assert_eq!(cached.value_range().max, 30393.0 * 2.0 - 10.0);
    assert_eq!(cached.value(1234), volume.value(1234));
}

/// Opens `name` from the shared data with a private cache.
fn open_cached(name: &str, cache: &std::path::Path) -> volasso::volume::Volume {
    let options = OpenOptions { cache_dir: Some(cache.to_path_buf()), ..OpenOptions::default() };
    open(&data(name), &options).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn assert_close(found: [f64; 3], expected: [f64; 3], what: &str) {
    assert!(found.iter().zip(&expected).all(|(f, e)| (f - e).abs() < 1e-4), "{what}: {found:?} != {expected:?}");
}

/// Letters and directions read by hand from each header (nibabel, pydicom, pynrrd): the
/// series and the NIfTI are patient scans; tooth.nrrd names LPS; frog.nrrd gives only a
/// `space dimension` (no patient frame); raw files say nothing.
#[test]
fn shared_files_pin_their_patient_orientation_through_the_cache() {
    const LPS: Option<[&str; 3]> = Some(["L", "P", "S"]);
    let expected = [
        ("anatomical.nii", Some(["L", "A", "S"])),
        ("tooth.nrrd", LPS),
        ("frog.nrrd", None),
        ("dicom/philips_phantom_5mm", LPS),
        ("dicom/ge_head_tilt", LPS),
        ("dicom/ct_small.dcm", LPS),
        ("engine_256x256x256_uint8.raw", None),
        ("cranium_ct_256x256x108_int16.raw", None),
    ];
    let cache = tempfile::tempdir().unwrap();
    for (name, letters) in expected {
        // Twice: DICOM series are imported into the cache, then read back from it.
        for pass in ["first open", "cache hit"] {
            let volume = open_cached(name, cache.path());
            assert_eq!(volume.orientation.map(|o| o.anatomical_letters()), letters, "{name}, {pass}");
        }
    }
    // The tilted GE head keeps its oblique axes after resampling: y leans 18.5° from posterior
    // toward inferior, z from superior toward posterior. Its grid starts at the smallest
    // in-plane position of any slice (u -125, v -167.219) on the first slice (w -33.665).
    for pass in ["first open", "cache hit"] {
        let ge = open_cached("dicom/ge_head_tilt", cache.path()).orientation.unwrap();
        assert_close(ge.axis_direction_lps(0), [1.0, 0.0, 0.0], pass);
        assert_close(ge.axis_direction_lps(1), [0.0, 0.948324, -0.317305], pass);
        assert_close(ge.axis_direction_lps(2), [0.0, 0.317305, 0.948324], pass);
        assert_close(ge.origin_lps_mm.unwrap(), [-125.0, -169.260367, 21.133724], pass);
    }
    let philips = open_cached("dicom/philips_phantom_5mm", cache.path()).orientation.unwrap();
    assert_close(philips.origin_lps_mm.unwrap(), [-115.5, -1.85, 696.21], "philips origin");
    let single = open_cached("dicom/ct_small.dcm", cache.path()).orientation.unwrap();
    assert_close(single.origin_lps_mm.unwrap(), [-158.135803, -179.035797, -75.699997], "ct_small origin");
    // anatomical.nii: qform and sform diag(-2, 2, 2) + (32, -40, -16) in RAS.
    let nifti = open_cached("anatomical.nii", cache.path()).orientation.unwrap();
    assert_close(nifti.axis_direction_lps(1), [0.0, -1.0, 0.0], "anatomical y");
    assert_close(nifti.origin_lps_mm.unwrap(), [-32.0, 40.0, -16.0], "anatomical origin");
}

/// Files written here with known flipped and permuted axes read back with those axes, and a
/// compressed file keeps them through the import cache.
#[test]
fn written_files_with_known_directions_read_back_their_orientation() {
    let folder = tempfile::tempdir().unwrap();
    let options = OpenOptions { cache_dir: Some(folder.path().join("cache")), ..OpenOptions::default() };
    let letters = |name: &str| {
        let path = folder.path().join(name);
        (0..2).map(|_| open(&path, &options).unwrap().orientation.map(|o| o.anatomical_letters())).collect::<Vec<_>>()
    };
    let voxels = [7u8; 24];
    // NRRD in RAS, x along -y (toward posterior... in RAS -A is P), y along +x (right), z up.
    let mut nrrd = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 3 4\nspace: right-anterior-superior\nspace directions: (0,-1,0) (1.5,0,0) (0,0,2)\nspace origin: (10,20,30)\nencoding: raw\n\n".to_vec();
    nrrd.extend_from_slice(&voxels);
    std::fs::write(folder.path().join("ras.nrrd"), &nrrd).unwrap();
    assert_eq!(letters("ras.nrrd"), vec![Some(["P", "R", "S"]); 2]);
    // The same as gzip: imported into the cache, then a cache hit.
    let mut gzip = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 3 4\nspace: left-posterior-superior\nspace directions: (0,0,-2) (1.5,0,0) (0,-1,0)\nencoding: gzip\n\n".to_vec();
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut encoder, &voxels).unwrap();
    gzip.extend(encoder.finish().unwrap());
    std::fs::write(folder.path().join("lps.nrrd"), &gzip).unwrap();
    assert_eq!(letters("lps.nrrd"), vec![Some(["I", "L", "A"]); 2]);
    // MetaImage: TransformMatrix lists axis x's direction first (here toward superior).
    let mut mha = b"ObjectType = Image\nNDims = 3\nDimSize = 2 3 4\nOffset = 1 2 3\nTransformMatrix = 0 0 1 -1 0 0 0 1 0\nAnatomicalOrientation = SRP\nElementSpacing = 1 1 1\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n".to_vec();
    mha.extend_from_slice(&voxels);
    std::fs::write(folder.path().join("v.mha"), &mha).unwrap();
    assert_eq!(letters("v.mha"), vec![Some(["S", "R", "P"]); 2]);
    // NIfTI (big-endian anatomical.nii) with an sform that swaps x and y and flips z: it wins
    // over the qform, and survives gzip and the cache.
    let mut nifti = std::fs::read(data("anatomical.nii")).unwrap();
    nifti[254..256].copy_from_slice(&1i16.to_be_bytes());
    let srow = [[0.0f32, 2.0, 0.0, 5.0], [2.0, 0.0, 0.0, 6.0], [0.0, 0.0, -2.0, 7.0]];
    for (row, values) in srow.iter().enumerate() {
        for (column, value) in values.iter().enumerate() {
            let offset = 280 + 16 * row + 4 * column;
            nifti[offset..offset + 4].copy_from_slice(&value.to_be_bytes());
        }
    }
    std::fs::write(folder.path().join("swapped.nii"), &nifti).unwrap();
    assert_eq!(letters("swapped.nii"), vec![Some(["A", "R", "I"]); 2]);
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut encoder, &nifti).unwrap();
    std::fs::write(folder.path().join("swapped.nii.gz"), encoder.finish().unwrap()).unwrap();
    assert_eq!(letters("swapped.nii.gz"), vec![Some(["A", "R", "I"]); 2]);
}

/// The scans `info` and the work screen open: every shared volume and DICOM series.
const SHARED_SCANS: [&str; 10] = [
    "engine_256x256x256_uint8.raw",
    "lobster_301x324x56_uint8.raw",
    "vismale_128x256x256_uint8.raw",
    "cranium_ct_256x256x108_int16.raw",
    "tooth.nrrd",
    "frog.nrrd",
    "anatomical.nii",
    "dicom/ge_head_tilt",
    "dicom/philips_phantom_5mm",
    "dicom/ct_small.dcm",
];

/// Voxels at or above `threshold` in every slice of every axis, counted plane by plane.
fn foreground_counts(volume: &volasso::volume::Volume, threshold: f64) -> [Vec<u64>; 3] {
    let [nx, ny, nz] = volume.dims;
    let mut counts = [vec![0u64; nx], vec![0u64; ny], vec![0u64; nz]];
    let mut plane = vec![0f32; nx * ny];
    for z in 0..nz {
        volume.read_z_slice_f32(z, &mut plane);
        for (index, &value) in plane.iter().enumerate() {
            if value as f64 >= threshold {
                counts[0][index % nx] += 1;
                counts[1][index / nx] += 1;
                counts[2][z] += 1;
            }
        }
    }
    counts
}

#[test]
fn top_slices_lie_in_the_central_80_percent_of_the_foreground_for_every_shared_scan() {
    use volasso::slices::{Axis, central_band, foreground_extent, foreground_slice_entropies, slice_entropies};
    let cache = tempfile::tempdir().unwrap();
    let options = OpenOptions { cache_dir: Some(cache.path().to_path_buf()), ..OpenOptions::default() };
    for name in SHARED_SCANS {
        let volume = open(&data(name), &options).unwrap_or_else(|e| panic!("{name}: {e}"));
        let started = std::time::Instant::now();
        let ranked = foreground_slice_entropies(&volume);
        let seconds = started.elapsed().as_secs_f64();
        let plain = slice_entropies(&volume).top_slices();
        let counts = foreground_counts(&volume, volume.otsu_threshold());
        let mut report = Vec::new();
        for axis in Axis::ALL {
            let extent = foreground_extent(&counts[axis.position()]).expect("every scan has foreground");
            let band = central_band(extent.clone());
            let top = ranked.axis(axis).top();
            assert!(band.contains(&top), "{name} {axis}: top slice {top} outside {band:?} (extent {extent:?})");
            report.push(format!("{axis} {top} in {band:?} of {extent:?} (plain {})", plain[axis.position()]));
        }
        println!("{name}: {} ({seconds:.3} s)", report.join(", "));
    }
}
