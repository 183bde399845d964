use super::*;
use crate::features::FeatureError;
use crate::features::tests::volume_from;
use crate::rng::SplitMix64;

fn slab_features(volume: &Volume, scales: Scales) -> Vec<f32> {
    let mut reader = MultiscaleSlabReader::new(volume, scales);
    let plane = volume.dims[0] * volume.dims[1];
    let selected: Vec<usize> = (0..plane).collect();
    let mut all = Vec::new();
    let mut block = Vec::new();
    for z in 0..volume.dims[2] {
        reader.compute_selected(z, &selected, &mut block);
        all.extend_from_slice(&block);
    }
    all
}

#[test]
fn constant_and_linear_volumes() {
    let constant = volume_from([12, 11, 10], [1.0, 1.0, 1.0], |_, _, _| 7.5);
    for row in slab_features(&constant, Scales::Full).chunks_exact(MULTISCALE_DIM) {
        assert_eq!(&row[..5], &[7.5; 5]);
        assert!(row[5..].iter().all(|&v| v == 0.0), "{row:?}");
    }
    // A ramp along x of 3 per voxel at 0.5 mm spacing: 6 per mm. Away from the borders (where
    // clamping bends it) every scale keeps the ramp, its slope and zero curvature.
    let ramp = volume_from([40, 9, 8], [0.5, 1.0, 2.0], |x, _, _| 3.0 * x as f32);
    let features = slab_features(&ramp, Scales::Full);
    for x in 12..28 {
        let row = &features[(x + 40 * (4 + 9 * 4)) * MULTISCALE_DIM..][..MULTISCALE_DIM];
        for stage in 1..5 {
            assert!((row[stage] - 3.0 * x as f32).abs() < 1e-3, "x {x}: {row:?}");
            assert!((row[4 + stage] - 6.0).abs() < 1e-3, "x {x}: {row:?}");
        }
        assert!(row[9..15].iter().all(|v| v.abs() < 1e-2), "x {x}: {row:?}");
    }
}

#[test]
fn the_cascade_spreads_an_impulse_by_the_stated_variances() {
    // An impulse in the middle of a long x line: stage k's response along x has variance
    // sum of r (r + 1) / 3 over the first k radii, i.e. 2/3, 4/3, 10/3, 10.
    let volume = volume_from([61, 1, 1], [1.0, 1.0, 1.0], |x, _, _| if x == 30 { 1.0 } else { 0.0 });
    let mut block = MultiscaleBlock::new(&volume, Scales::Full);
    block.compute(&volume, [0..61, 0..1, 0..1]);
    for (stage, expected) in [(1, 2.0 / 3.0), (2, 4.0 / 3.0), (3, 10.0 / 3.0), (4, 10.0)] {
        let (mut mass, mut variance) = (0.0, 0.0);
        for x in 0..61 {
            let value = block.at(stage, x, 0, 0) as f64;
            mass += value;
            variance += value * (x as f64 - 30.0).powi(2);
        }
        assert!((mass - 1.0).abs() < 1e-5);
        assert!((variance - expected).abs() < 1e-4, "stage {stage}: {variance}");
    }
}

#[test]
fn training_tiles_and_whole_volume_blocks_agree_bit_for_bit() {
    let mut rng = SplitMix64::new(11);
    let dims = [37, 29, 41];
    let volume = volume_from(dims, [0.7, 1.1, 1.6], |_, _, _| (rng.next_f64() * 2000.0 - 1000.0) as f32);
    let mut pick = SplitMix64::new(12);
    let mut indices: Vec<usize> = (0..600).map(|_| pick.below(volume.voxel_count() as u64) as usize).collect();
    // Corners and borders too.
    indices.extend([0, dims[0] - 1, volume.voxel_count() - 1, dims[0] * dims[1] * 20]);
    for scales in [Scales::Fine, Scales::Full] {
        let all = slab_features(&volume, scales);
        let dim = scales.dim();
        let features = multiscale_features_of_voxels(&volume, scales, &indices).unwrap();
        for (k, &index) in indices.iter().enumerate() {
            assert_eq!(&all[index * dim..][..dim], &features[k * dim..][..dim], "voxel {index} ({scales:?})");
        }
        // The fine set is the full set's first scales.
        if scales == Scales::Fine {
            let full = multiscale_features_of_voxels(&volume, Scales::Full, &indices).unwrap();
            for (fine, full) in features.chunks_exact(dim).zip(full.chunks_exact(MULTISCALE_DIM)) {
                assert_eq!(
                    [fine[0], fine[1], fine[2], fine[3], fine[4]],
                    [full[0], full[1], full[2], full[5], full[6]]
                );
                assert_eq!(&fine[5..9], &[full[9], full[10], full[11], full[15]]);
            }
        }
    }
    assert!(matches!(
        multiscale_features_of_voxels(&volume, Scales::Full, &[volume.voxel_count()]),
        Err(FeatureError::VoxelOutOfRange { .. })
    ));
}

#[test]
fn a_thin_bright_sheet_differs_from_a_thick_edge_of_the_same_value() {
    // x < 20: 0; a one-voxel sheet of 100 at x = 10; a thick slab of 200 from x = 30 blurred
    // so that one voxel at its border reads 100. Both centre voxels read 100, but the sheet is
    // a ridge (strongly negative curvature across it, no gradient) and the edge is a slope.
    let volume = volume_from([48, 20, 20], [1.0, 1.0, 1.0], |x, _, _| match x {
        10 => 100.0,
        30 => 100.0,
        x if x > 30 => 200.0,
        _ => 0.0,
    });
    let features =
        multiscale_features_of_voxels(&volume, Scales::Full, &[10 + 48 * (10 + 20 * 10), 30 + 48 * (10 + 20 * 10)])
            .unwrap();
    let (sheet, edge) = features.split_at(MULTISCALE_DIM);
    assert_eq!(sheet[0], edge[0]);
    assert!(sheet[5] < 0.1 * edge[5], "gradient: sheet {} edge {}", sheet[5], edge[5]);
    assert!(sheet[9] < -20.0 && edge[9] > -20.0, "curvature: sheet {} edge {}", sheet[9], edge[9]);
    assert!(sheet[15] > 30.0 && edge[15].abs() < 30.0, "DoG: sheet {} edge {}", sheet[15], edge[15]);
}

#[test]
fn block_depth_respects_the_budget_where_it_can() {
    // 256 planes: at least 12 blocks. 56 planes: not below 8 for balance alone.
    assert_eq!(block_depth([128, 256, 256]), 20);
    assert_eq!(block_depth([128, 256, 1024]), MAX_BLOCK_DEPTH);
    assert_eq!(block_depth([301, 324, 56]), 8);
    let engine = block_depth([256, 256, 256]);
    assert!((6 * engine + 78) * 256 * 256 * 4 <= BLOCK_BUDGET_BYTES, "{engine}");
    assert_eq!(block_depth([1024, 1024, 300]), MIN_BLOCK_DEPTH);
}

#[test]
fn the_avx2_variants_give_the_portable_bits() {
    // Noise, a bright sheet and flat (diagonal-Hessian) regions, odd sizes and unequal spacing,
    // every voxel of the block including its faces; both scale sets.
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2_fma() {
        let mut rng = SplitMix64::new(21);
        let volume = volume_from([23, 19, 14], [0.7, 1.1, 2.3], |x, y, z| match (x, y) {
            (0..4, _) => 100.0,
            (_, 9) => 900.0,
            _ => 400.0 * rng.next_f64() as f32 + 10.0 * z as f32,
        });
        let voxels: Vec<[usize; 3]> =
            (0..14).flat_map(|z| (0..19).flat_map(move |y| (0..23).map(move |x| [x, y, z]))).collect();
        for scales in [Scales::Fine, Scales::Full] {
            let mut block = MultiscaleBlock::new(&volume, scales);
            block.compute(&volume, [0..23, 0..19, 0..14]);
            let (mut wide, mut portable) =
                (vec![0f32; voxels.len() * scales.dim()], vec![0f32; voxels.len() * scales.dim()]);
            // SAFETY: the CPU has AVX2 and FMA, checked above.
            unsafe { block.features_of_avx2(&voxels, &mut wide) };
            block.features_of_lanes(&voxels, &mut portable);
            assert!(wide.iter().zip(&portable).all(|(a, b)| a.to_bits() == b.to_bits()), "{scales:?}");
        }
    }
}
