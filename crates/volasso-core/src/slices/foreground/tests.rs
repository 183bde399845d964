use super::*;
use crate::rng::SplitMix64;
use crate::slices::{ENTROPY_BINS, SliceGeometry, entropy_nats};
use crate::volume::{ByteOrder, ValueScale, VoxelBytes, VoxelType};
use std::path::Path;

/// Foreground entropy and count of one slice, the slow and obvious way.
fn foreground_entropy_by_hand(volume: &Volume, axis: Axis, slice: usize, threshold: f64) -> (f64, u64) {
    let range = volume.value_range();
    let binning = EntropyBinning::new(threshold.max(range.min), range.max);
    let geometry = SliceGeometry::new(volume.dims, axis, slice).unwrap();
    let mut counts = [0u32; ENTROPY_BINS];
    let mut counted = 0;
    for j in 0..geometry.height {
        for i in 0..geometry.width {
            let value = volume.value(geometry.voxel_index(i, j));
            if let Some(bin) = binning.bin(value).filter(|_| value >= threshold) {
                counts[bin] += 1;
                counted += 1;
            }
        }
    }
    (entropy_nats(&counts), counted)
}

fn volume_of(dims: [usize; 3], voxel_type: VoxelType, bytes: Vec<u8>) -> Volume {
    let scale = ValueScale::IDENTITY;
    Volume::new(dims, [1.0; 3], voxel_type, ByteOrder::Little, scale, VoxelBytes::Owned(bytes), Path::new("t")).unwrap()
}

#[test]
fn the_extent_ignores_specks_and_the_band_keeps_the_central_80_percent() {
    assert_eq!(foreground_extent(&[0, 0, 0]), None);
    assert_eq!(foreground_extent(&[]), None);
    // 2 voxels (under 1 % of the fullest slice's 1000) are specks; 10 are not.
    assert_eq!(foreground_extent(&[2, 10, 500, 1000, 800, 3, 0]), Some(1..=4));
    assert_eq!(foreground_extent(&[0, 1, 0]), Some(1..=1));
    // Slice centres inside [first - 0.5 + L/10, last + 0.5 - L/10].
    assert_eq!(central_band(0..=24), 2..=22);
    assert_eq!(central_band(0..=9), 1..=8);
    assert_eq!(central_band(0..=179), 18..=161);
    assert_eq!(central_band(3..=4), 3..=4);
    assert_eq!(central_band(5..=5), 5..=5);
}

#[test]
fn foreground_entropies_count_only_voxels_at_or_above_the_threshold() {
    let mut rng = SplitMix64::new(7);
    let dims = [11, 6, 9];
    let count = dims.iter().product::<usize>();
    let bytes: Vec<u8> =
        (0..count).map(|i| if i % 5 == 0 { rng.below(20) as u8 } else { 60 + rng.below(190) as u8 }).collect();
    let words: Vec<u8> =
        (0..count).flat_map(|i| ((i as i16 % 77) * 40 - 1024 + rng.below(200) as i16).to_le_bytes()).collect();
    let floats: Vec<f32> = (0..count).map(|i| if i % 13 == 0 { f32::NAN } else { (i % 17) as f32 * 3.5 }).collect();
    let volumes = [
        (volume_of(dims, VoxelType::U8, bytes), 50.0),
        (volume_of(dims, VoxelType::I16, words), 300.0),
        (Volume::from_f32(dims, [1.0; 3], &floats, Path::new("t")).unwrap(), 20.0),
    ];
    for (volume, threshold) in &volumes {
        let ranked = foreground_slice_entropies_above(volume, *threshold);
        for axis in Axis::ALL {
            let slices = ranked.axis(axis);
            let mut counts = Vec::new();
            for slice in 0..volume.dims[axis.position()] {
                let (expected, counted) = foreground_entropy_by_hand(volume, axis, slice, *threshold);
                assert!(
                    (slices.entropies_nats[slice] - expected).abs() < 1e-9,
                    "{:?} {axis} {slice}",
                    volume.voxel_type
                );
                counts.push(counted);
            }
            let band = foreground_extent(&counts).map(central_band);
            assert_eq!(slices.preferred_slices(), band, "{:?} {axis}", volume.voxel_type);
        }
    }
    // Nothing at or above the threshold: the plain ranking.
    let (volume, _) = &volumes[0];
    assert_eq!(foreground_slice_entropies_above(volume, 1e9), crate::slices::slice_entropies(volume));
    assert_eq!(foreground_slice_entropies_above(volume, f64::NAN), crate::slices::slice_entropies(volume));
}

/// A head cut off at the neck: tissue with a skull and a brain, in noisy air, reaching z = 0
/// with a wide cross-section; the two planes at the cut are noise and partial anatomy.
fn neck_cut_head() -> Volume {
    let dims = [40, 40, 70];
    let mut rng = SplitMix64::new(20);
    let mut values = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let r = |c: usize, centre: f64, radius: f64| (c as f64 - centre) / radius;
                let head = r(x, 20.0, 16.0).powi(2) + r(y, 20.0, 18.0).powi(2) + r(z, 30.0, 40.0).powi(2);
                let brain = r(x, 20.0, 11.0).powi(2) + r(y, 20.0, 13.0).powi(2) + r(z, 38.0, 24.0).powi(2);
                let value = if head > 1.0 {
                    rng.below(8) as f32
                } else if z < 2 {
                    40.0 + rng.below(211) as f32
                } else if brain <= 1.0 {
                    140.0 + rng.below(4) as f32
                } else if head > 0.75 {
                    220.0 + rng.below(4) as f32
                } else {
                    100.0 + rng.below(4) as f32
                };
                values.push(value);
            }
        }
    }
    Volume::from_f32(dims, [1.0; 3], &values, Path::new("neck")).unwrap()
}

#[test]
fn a_head_cut_at_the_neck_opens_inside_the_body_not_on_the_cut() {
    let volume = neck_cut_head();
    let plain = crate::slices::slice_entropies(&volume);
    assert!(plain.z.top() <= 1, "the plain ranking picks the cut, z = {}", plain.z.top());

    let ranked = foreground_slice_entropies(&volume);
    let threshold = volume.otsu_threshold();
    let counts: Vec<u64> =
        (0..volume.dims[2]).map(|z| foreground_entropy_by_hand(&volume, Axis::Z, z, threshold).1).collect();
    let extent = foreground_extent(&counts).unwrap();
    assert_eq!(*extent.start(), 0, "the head reaches the cut");
    let band = central_band(extent);
    assert_eq!(ranked.z.preferred_slices(), Some(band.clone()));
    assert!(*band.start() >= 6, "{band:?}");
    for axis in Axis::ALL {
        let slices = ranked.axis(axis);
        let band = slices.preferred_slices().unwrap();
        assert!(band.contains(&slices.top()), "{axis}: {} outside {band:?}", slices.top());
        // Ranked by information (entropy x foreground voxels): the top slice goes through the
        // head's bulk, not a rim grazing its surface.
        let foreground: Vec<u64> = (0..volume.dims[axis.position()])
            .map(|slice| foreground_entropy_by_hand(&volume, axis, slice, threshold).1)
            .collect();
        let fullest = foreground.iter().copied().max().unwrap();
        assert!(
            foreground[slices.top()] * 2 >= fullest,
            "{axis}: top {} holds {} of {fullest}",
            slices.top(),
            foreground[slices.top()]
        );
        let information = |slice: usize| slices.entropies_nats[slice] * foreground[slice] as f64;
        assert!(band.clone().all(|slice| information(slice) <= information(slices.top())), "{axis}");
        // Every slice stays reachable by rank, the band's first.
        assert_eq!(slices.preferred_count, band.clone().count());
        assert!(slices.order[..slices.preferred_count].iter().all(|s| band.contains(s)));
        let mut sorted = slices.order.clone();
        sorted.sort();
        assert_eq!(sorted, (0..volume.dims[axis.position()]).collect::<Vec<_>>());
    }
}
