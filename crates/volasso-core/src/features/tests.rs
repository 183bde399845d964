use super::*;
use crate::rng::SplitMix64;
use std::path::Path;

/// A volume whose voxel (x, y, z) holds `f(x, y, z)`; also used by `multiscale::tests`.
pub(super) fn volume_from(
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    mut f: impl FnMut(usize, usize, usize) -> f32,
) -> Volume {
    let mut values = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                values.push(f(x, y, z));
            }
        }
    }
    Volume::from_f32(dims, spacing_mm, &values, Path::new("test")).unwrap()
}

fn random_volume(dims: [usize; 3], seed: u64) -> Volume {
    let mut rng = SplitMix64::new(seed);
    volume_from(dims, [0.7, 1.1, 2.5], |_, _, _| (rng.next_f64() * 2000.0 - 1000.0) as f32)
}

fn all_slab_features(volume: &Volume) -> Vec<f32> {
    let mut reader = FeatureSlabReader::new(volume, FeatureSet::Paper5);
    let mut out = Vec::new();
    reader.compute(0..volume.dims[2], &mut out).unwrap();
    out
}

#[test]
fn a_constant_volume_has_zero_gradient_and_means_equal_to_the_constant() {
    let volume = volume_from([5, 4, 3], [0.8, 0.8, 1.2], |_, _, _| 42.5);
    let features = all_slab_features(&volume);
    assert_eq!(features.len(), 5 * 60);
    for row in features.chunks_exact(5) {
        assert_eq!(row, &[42.5, 0.0, 42.5, 42.5, 42.5]);
    }
    for index in 0..volume.voxel_count() {
        assert_eq!(features_at(&volume, index), [42.5, 0.0, 42.5, 42.5, 42.5]);
    }
}

#[test]
fn a_linear_ramp_has_its_exact_gradient_in_physical_units_everywhere() {
    let spacing_mm = [0.5, 2.0, 4.0];
    // Per voxel step: 3 along x, -8 along y, 20 along z: per mm 6, -4, 5.
    let volume = volume_from([6, 5, 4], spacing_mm, |x, y, z| 3.0 * x as f32 - 8.0 * y as f32 + 20.0 * z as f32);
    let expected = (36f32 + 16.0 + 25.0).sqrt();
    let features = all_slab_features(&volume);
    for (index, row) in features.chunks_exact(5).enumerate() {
        assert!((row[1] - expected).abs() < 1e-4, "voxel {index}: {}", row[1]);
    }
    // In the interior every plane mean of a linear function is the centre value.
    let centre = volume.index(2, 2, 1);
    let row = &features[centre * 5..centre * 5 + 5];
    assert_eq!(row[0], 6.0 - 16.0 + 20.0);
    assert_eq!(&row[2..], &[row[0]; 3]);
}

#[test]
fn anisotropic_spacing_scales_each_axis_of_the_gradient() {
    // The same voxel steps along x and z, but z voxels are 3 mm apart: its slope is a third.
    let volume = volume_from([4, 4, 4], [1.0, 1.0, 3.0], |_, _, z| 30.0 * z as f32);
    assert!((features_at(&volume, volume.index(1, 1, 1))[1] - 10.0).abs() < 1e-5);
    let volume = volume_from([4, 4, 4], [1.0, 1.0, 3.0], |x, _, _| 30.0 * x as f32);
    assert!((features_at(&volume, volume.index(1, 1, 1))[1] - 30.0).abs() < 1e-5);
}

#[test]
fn plane_means_take_the_eight_in_plane_neighbours_and_clamp_at_the_edge() {
    // value = 100 z + 10 y + x on a 3x3x3 grid.
    let volume = volume_from([3, 3, 3], [1.0; 3], |x, y, z| (100 * z + 10 * y + x) as f32);
    let centre = features_at(&volume, volume.index(1, 1, 1));
    assert_eq!(centre, [111.0, (1f32 + 100.0 + 10000.0).sqrt(), 111.0, 111.0, 111.0]);
    // Corner (0,0,0): xy neighbours clamp to (0|1, 0|1, 0): {0,0,1,0,1,10,10,11} -> 33/8.
    let corner = features_at(&volume, 0);
    assert_eq!(corner[2], 33.0 / 8.0);
    // xz: {0,0,1,0,1,100,100,101} -> 303/8; yz: {0,0,10,0,10,100,100,110} -> 330/8.
    assert_eq!(corner[3], 303.0 / 8.0);
    assert_eq!(corner[4], 330.0 / 8.0);
    // One-sided differences at the corner: 1, 10 and 100 per mm.
    assert_eq!(corner[1], (1f32 + 100.0 + 10000.0).sqrt());
}

#[test]
fn a_flat_axis_contributes_no_gradient_and_does_not_panic() {
    let volume = volume_from([4, 1, 1], [1.0; 3], |x, _, _| 2.0 * x as f32);
    let features = all_slab_features(&volume);
    for row in features.chunks_exact(5) {
        assert_eq!(row[1], 2.0);
    }
}

#[test]
fn slabs_equal_per_voxel_features_bit_for_bit_in_any_order_of_calls() {
    let volume = random_volume([9, 7, 8], 5);
    let dim = 5;
    let plane = 9 * 7;
    let per_voxel: Vec<f32> = (0..volume.voxel_count()).flat_map(|index| features_at(&volume, index)).collect();
    assert_eq!(all_slab_features(&volume), per_voxel);
    // One reader, slabs forward, backward and overlapping: the rolling buffer must not leak.
    let mut reader = FeatureSlabReader::new(&volume, FeatureSet::Paper5);
    let mut block = Vec::new();
    for z_range in [0..3, 3..5, 5..8, 1..2, 7..8, 0..1, 2..6, 4..4] {
        reader.compute(z_range.clone(), &mut block).unwrap();
        assert_eq!(block, per_voxel[z_range.start * plane * dim..z_range.end * plane * dim], "{z_range:?}");
    }
    let listed = features_of_voxels(&volume, FeatureSet::Paper5, &[17, 0, 503]).unwrap();
    assert_eq!(&listed[..5], &per_voxel[17 * 5..18 * 5]);
    assert_eq!(&listed[10..], &per_voxel[503 * 5..504 * 5]);
}

#[test]
fn the_gap_set_reads_the_same_values_by_voxel_by_slab_and_by_selection() {
    let volume = random_volume([9, 7, 13], 21);
    let set = FeatureSet::Paper5Gap;
    let (dim, plane) = (set.dim(), 9 * 7);
    let every: Vec<usize> = (0..volume.voxel_count()).collect();
    let per_voxel = features_of_voxels(&volume, set, &every).unwrap();
    for (index, row) in per_voxel.chunks_exact(dim).enumerate() {
        assert_eq!(row[..5], features_at(&volume, index), "voxel {index}");
    }
    for depth in [1, 4, 16] {
        let blocks = par_map_slabs(&volume, set, depth, |_, block| block.to_vec());
        assert_eq!(blocks.concat(), per_voxel, "depth {depth}");
    }
    // Planes in the orders coarse-to-fine asks for them: every second one, then the rest.
    let mut reader = FeatureSlabReader::new(&volume, set);
    let mut block = Vec::new();
    for z in (0..13).step_by(2).chain((1..13).step_by(2)).chain([5, 0, 12]) {
        let selected: Vec<usize> = (0..plane).filter(|i| (i + z) % 3 != 0).collect();
        reader.compute_selected(z, &selected, &mut block).unwrap();
        let expected: Vec<f32> =
            selected.iter().flat_map(|&i| per_voxel[(z * plane + i) * dim..][..dim].to_vec()).collect();
        assert_eq!(block, expected, "z {z}");
    }
}

#[test]
fn the_gap_set_within_the_foregrounds_box_reads_the_whole_volumes_values() {
    // Foreground (at or above 0) in a box away from every face but one: the planes are
    // computed only around it, and each foreground voxel's depth is still the volume's.
    let mut rng = SplitMix64::new(4);
    let volume = volume_from([20, 16, 9], [1.0; 3], |x, y, _| {
        let inside = (6..11).contains(&x) && (0..7).contains(&y);
        (rng.next_f64() * 1000.0) as f32 - if inside { 0.0 } else { 2000.0 }
    });
    let rows = crate::volume::ForegroundRows::find(&volume, 0.0);
    let mut reader = FeatureSlabReader::new(&volume, FeatureSet::Paper5Gap).with_foreground_rows(&rows);
    let plane = 20 * 16;
    let mut block = Vec::new();
    for z in (0..9).step_by(2).chain((1..9).step_by(2)) {
        let selected: Vec<usize> = (0..plane).filter(|&i| volume.value(z * plane + i) >= 0.0).collect();
        assert_eq!(selected.len(), 35);
        reader.compute_selected(z, &selected, &mut block).unwrap();
        let indices: Vec<usize> = selected.iter().map(|i| z * plane + i).collect();
        assert_eq!(block, features_of_voxels(&volume, FeatureSet::Paper5Gap, &indices).unwrap(), "z {z}");
    }
}

#[test]
fn selected_voxels_of_a_slice_equal_per_voxel_features() {
    let volume = random_volume([9, 7, 8], 11);
    let plane = 9 * 7;
    let mut reader = FeatureSlabReader::new(&volume, FeatureSet::Paper5);
    let mut block = Vec::new();
    for (z, selected) in [(0usize, vec![0usize, 8, 62]), (7, vec![5, 30]), (3, vec![]), (4, (0..plane).collect())] {
        reader.compute_selected(z, &selected, &mut block).unwrap();
        let expected: Vec<f32> = selected.iter().flat_map(|&i| features_at(&volume, z * plane + i)).collect();
        assert_eq!(block, expected, "z {z}");
    }
    assert!(reader.compute_selected(8, &[0], &mut block).is_err());
    assert!(reader.compute_selected(2, &[plane], &mut block).is_err());
}

#[test]
fn parallel_slabs_cover_the_volume_in_order() {
    let volume = random_volume([6, 5, 11], 9);
    let expected = all_slab_features(&volume);
    for depth in [0, 1, 3, 11, 50] {
        let blocks = par_map_slabs(&volume, FeatureSet::Paper5, depth, |z_range, block| {
            assert_eq!(block.len(), z_range.len() * 30 * 5);
            block.to_vec()
        });
        assert_eq!(blocks.concat(), expected, "depth {depth}");
    }
    assert_eq!(slab_ranges(7, 3), vec![0..3, 3..6, 6..7]);
}

#[test]
fn out_of_range_voxels_and_slabs_are_errors() {
    let volume = random_volume([3, 3, 3], 1);
    assert_eq!(
        features_of_voxels(&volume, FeatureSet::Paper5, &[3, 27]),
        Err(FeatureError::VoxelOutOfRange { index: 27, voxel_count: 27 })
    );
    let mut reader = FeatureSlabReader::new(&volume, FeatureSet::Paper5);
    assert_eq!(
        reader.compute(2..4, &mut Vec::new()),
        Err(FeatureError::SlabOutOfRange { z_start: 2, z_end: 4, size_z: 3 })
    );
}

#[test]
fn the_standardiser_centres_and_scales_and_passes_constant_features() {
    let vectors = [1.0f32, 5.0, 10.0, 3.0, 5.0, 20.0, 5.0, 5.0, 30.0];
    let standardiser = Standardiser::fit(&vectors, 3).unwrap();
    assert_eq!(standardiser.mean, vec![3.0, 5.0, 20.0]);
    assert_eq!(standardiser.std[1], 1.0);
    let standardised = standardiser.apply(&vectors).unwrap();
    for feature in [0, 2] {
        let column: Vec<f64> = standardised.iter().skip(feature).step_by(3).copied().collect();
        let mean = column.iter().sum::<f64>() / 3.0;
        let variance = column.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / 3.0;
        assert!(mean.abs() < 1e-12 && (variance - 1.0).abs() < 1e-12);
    }
    assert_eq!(standardised[1], 0.0);
    let mut block = vectors;
    standardiser.apply_in_place(&mut block).unwrap();
    for (a, b) in block.iter().zip(&standardised) {
        assert!((*a as f64 - b).abs() < 1e-6);
    }
}

#[test]
fn standardising_in_place_clamps_each_feature_in_long_blocks_and_keeps_nan() {
    let dim = 3;
    let training: Vec<f32> = (0..30).map(|i| (i * 7 % 11) as f32 * (1 + i % dim) as f32).collect();
    let standardiser = Standardiser::fit(&training, dim).unwrap();
    // 37 rows: two runs of 16 and a remainder, with values beyond the training range.
    let mut block: Vec<f32> = (0..37 * dim).map(|i| (i as f32 - 40.0) * 0.9).collect();
    block[50] = f32::NAN;
    let expected: Vec<f32> = block
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let k = i % dim;
            let clamped = v.clamp(standardiser.training_low[k] as f32, standardiser.training_high[k] as f32);
            (clamped - standardiser.mean[k] as f32) * (1.0 / standardiser.std[k]) as f32
        })
        .collect();
    standardiser.apply_in_place(&mut block).unwrap();
    assert!(block[50].is_nan());
    for (i, (a, b)) in block.iter().zip(&expected).enumerate() {
        assert!(i == 50 || a == b, "value {i}: {a} != {b}");
    }
}

#[test]
fn the_standardiser_refuses_bad_training_vectors() {
    assert_eq!(Standardiser::fit(&[], 5), Err(FeatureError::NoVectors));
    assert_eq!(Standardiser::fit(&[1.0; 7], 5), Err(FeatureError::Ragged { length: 7, dim: 5 }));
    assert!(matches!(
        Standardiser::fit(&[1.0, 2.0, 3.0, f32::NAN], 2),
        Err(FeatureError::NonFinite { vector: 1, feature: 1, .. })
    ));
    let standardiser = Standardiser::fit(&[1.0, 2.0], 2).unwrap();
    assert!(standardiser.apply(&[1.0, 2.0, 3.0]).is_err());
}

#[test]
fn a_weighted_standardisation_scales_each_feature_after_it_in_both_paths() {
    let training = [0.0f32, 10.0, 2.0, 30.0, 4.0, 50.0];
    let plain = Standardiser::fit(&training, 2).unwrap();
    let weighted = plain.clone().weighted(&[1.0, 0.25]);
    let (a, b) = (plain.apply(&training).unwrap(), weighted.apply(&training).unwrap());
    for (row, (a, b)) in a.chunks(2).zip(b.chunks(2)).enumerate() {
        assert!((a[0] - b[0]).abs() < 1e-12, "row {row}: the first feature keeps its weight");
        assert!((0.25 * a[1] - b[1]).abs() < 1e-12, "row {row}: the second counts a quarter");
    }
    let mut block = [2.0f32, 30.0];
    weighted.apply_in_place(&mut block).unwrap();
    assert!((block[1] as f64 - b[3]).abs() < 1e-6, "the prediction path weighs as training does");
    assert_eq!(plain.clone().weighted(&[1.0]), plain, "weights of another length change nothing");
    assert_eq!(plain.clone().weighted(&[1.0, 0.0]), plain, "a zero weight changes nothing");
    assert_eq!(FeatureSet::Paper5.scaling().weights[1], crate::features::PAPER5_GRADIENT_WEIGHT);
    assert!(FeatureSet::MultiscaleFine.scaling().weights.iter().all(|&w| w == 1.0));
}

#[test]
fn the_gap_depth_is_scaled_by_the_intensity_deviation_not_its_own() {
    // Intensities 0, 100, 200 (deviation 81.6) and a gap depth of noise, 0, 2, 4 (1.63):
    // on its own scale the noise would spread as far as the intensities do.
    let training = [0.0f32, 0.0, 100.0, 2.0, 200.0, 4.0];
    let own = Standardiser::fit(&training, 2).unwrap();
    let shared = own.clone().in_units_of(&[0, 0]);
    assert_eq!(shared.std, vec![own.std[0], own.std[0]]);
    assert_eq!(shared.mean, own.mean, "only the scale changes");
    let values = shared.apply(&training).unwrap();
    assert!((values[5] - values[1] - 4.0 / own.std[0]).abs() < 1e-12, "a gap of 4 is 4 intensity units apart");
    assert_eq!(own.clone().in_units_of(&[0]), own, "units of another length change nothing");
    assert_eq!(own.clone().in_units_of(&[0, 2]), own, "a unit out of range changes nothing");
    let scaling = FeatureSet::Paper5Gap.scaling();
    assert_eq!(scaling.unit_of[5], 0, "the gap depth is measured in intensities");
    assert_eq!(scaling.weights[5], crate::features::GAP_WEIGHT);
    let vectors: Vec<f32> = (0..12).map(|i| [1.0, 5.0, 1.0, 2.0, 3.0, 0.5][i % 6] * (1 + i / 6) as f32).collect();
    assert_eq!(scaling.dim(), 6);
    let fitted = scaling.fit(&vectors).unwrap();
    let plain = Standardiser::fit(&vectors, 6).unwrap();
    assert!((fitted.std[5] - plain.std[0] / crate::features::GAP_WEIGHT).abs() < 1e-9);
}

#[test]
fn engine_volume_features_by_parallel_slabs_match_per_voxel_and_report_throughput() {
    use crate::volume::{ByteOrder, ValueScale, VoxelBytes, VoxelType};
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/engine_256x256x256_uint8.raw"));
    let bytes = VoxelBytes::map_region(path, 0, 256 * 256 * 256).unwrap();
    let volume =
        Volume::new([256; 3], [1.0; 3], VoxelType::U8, ByteOrder::Little, ValueScale::IDENTITY, bytes, path).unwrap();
    let probes = [0usize, 256 * 256 * 128 + 256 * 100 + 77, 256 * 256 * 256 - 1];
    let started = std::time::Instant::now();
    let slabs = par_map_slabs(&volume, FeatureSet::Paper5, 4, |z_range, block| {
        let first = z_range.start * 256 * 256;
        let probed: Vec<(usize, [f32; 5])> = probes
            .iter()
            .filter(|&&p| p >= first && p < first + block.len() / 5)
            .map(|&p| {
                let row = &block[(p - first) * 5..(p - first + 1) * 5];
                (p, [row[0], row[1], row[2], row[3], row[4]])
            })
            .collect();
        let gradient_sum: f64 = block.iter().skip(1).step_by(5).map(|&g| g as f64).sum();
        (probed, gradient_sum)
    });
    let seconds = started.elapsed().as_secs_f64();
    println!(
        "Paper5 features of 256^3 engine: {seconds:.3} s, {:.0} Mvoxels/s on {} threads",
        volume.voxel_count() as f64 / seconds / 1e6,
        rayon::current_num_threads()
    );
    // One thread's CPU time for the same work (Linux), a figure that other load on the
    // machine does not distort.
    let cpu_seconds = || {
        std::fs::read_to_string("/proc/thread-self/schedstat")
            .ok()
            .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
            .map(|ns| ns / 1e9)
    };
    if let Some(before) = cpu_seconds() {
        let mut reader = FeatureSlabReader::new(&volume, FeatureSet::Paper5);
        let mut block = Vec::new();
        let mut checksum = 0f64;
        for z_range in slab_ranges(256, 4) {
            reader.compute(z_range, &mut block).unwrap();
            checksum += block[block.len() / 2] as f64;
        }
        let cpu = cpu_seconds().unwrap_or(before) - before;
        println!(
            "Paper5 features, one thread: {cpu:.3} CPU s, {:.0} Mvoxels per CPU second (checksum {checksum})",
            volume.voxel_count() as f64 / cpu / 1e6
        );
    }
    let probed: Vec<_> = slabs.iter().flat_map(|(p, _)| p.clone()).collect();
    assert_eq!(probed.len(), probes.len());
    for (index, features) in probed {
        assert_eq!(features, features_at(&volume, index));
    }
    assert!(slabs.iter().map(|(_, g)| g).sum::<f64>() > 0.0);
}

#[test]
fn intensities_are_told_from_gradients_and_curvatures_in_every_set() {
    assert_eq!(FeatureSet::Paper5.intensity_features(), [true, false, true, true, true]);
    assert_eq!(FeatureSet::Paper5Gap.intensity_features(), [true, false, true, true, true, false]);
    let fine = FeatureSet::MultiscaleFine.intensity_features();
    let marked: Vec<&str> =
        FeatureSet::MultiscaleFine.names().iter().zip(&fine).filter(|(_, m)| **m).map(|(n, _)| *n).collect();
    assert_eq!(marked, ["intensity", "smoothed s0.8", "smoothed s1.2"]);
    let full = FeatureSet::Multiscale.intensity_features();
    assert_eq!(full.len(), FeatureSet::Multiscale.dim());
    assert_eq!(full.iter().filter(|&&m| m).count(), 5, "the intensity and four smoothings");
}
