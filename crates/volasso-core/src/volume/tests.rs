//! Unit tests of the volume type: decoding, ranges, counts.

use super::*;

fn volume_from(bytes: Vec<u8>, voxel_type: VoxelType, order: ByteOrder, dims: [usize; 3]) -> Volume {
    Volume::new(dims, [1.0; 3], voxel_type, order, ValueScale::IDENTITY, VoxelBytes::Owned(bytes), Path::new("test"))
        .unwrap()
}

#[test]
fn reads_every_type_in_both_byte_orders() {
    let values = [-3.0f64, 0.0, 7.0, 100.0];
    for voxel_type in VoxelType::ALL {
        for order in [ByteOrder::Little, ByteOrder::Big] {
            let mut bytes = Vec::new();
            for &v in &values {
                let v = if matches!(voxel_type, VoxelType::U8 | VoxelType::U16 | VoxelType::U32) { v.abs() } else { v };
                let le: Vec<u8> = match voxel_type {
                    VoxelType::U8 => vec![v as u8],
                    VoxelType::I8 => vec![v as i8 as u8],
                    VoxelType::U16 => (v as u16).to_le_bytes().to_vec(),
                    VoxelType::I16 => (v as i16).to_le_bytes().to_vec(),
                    VoxelType::U32 => (v as u32).to_le_bytes().to_vec(),
                    VoxelType::I32 => (v as i32).to_le_bytes().to_vec(),
                    VoxelType::F32 => (v as f32).to_le_bytes().to_vec(),
                    VoxelType::F64 => v.to_le_bytes().to_vec(),
                };
                bytes.extend(if order == ByteOrder::Big { le.into_iter().rev().collect::<Vec<_>>() } else { le });
            }
            let volume = volume_from(bytes, voxel_type, order, [2, 2, 1]);
            let mut out = [0f32; 4];
            volume.read_f32(0, &mut out);
            for (i, &v) in values.iter().enumerate() {
                let expected =
                    if matches!(voxel_type, VoxelType::U8 | VoxelType::U16 | VoxelType::U32) { v.abs() } else { v };
                assert_eq!(volume.value(i), expected, "{voxel_type:?} {order:?}");
                assert_eq!(out[i] as f64, expected, "{voxel_type:?} {order:?}");
            }
        }
    }
}

#[test]
fn value_range_applies_the_scale_and_skips_non_finite_values() {
    let bytes: Vec<u8> = [1.0f32, f32::NAN, 5.0, f32::INFINITY].iter().flat_map(|v| v.to_le_bytes()).collect();
    let volume = Volume::new(
        [4, 1, 1],
        [1.0; 3],
        VoxelType::F32,
        ByteOrder::Little,
        ValueScale { slope: 2.0, intercept: -1.0 },
        VoxelBytes::Owned(bytes),
        Path::new("t"),
    )
    .unwrap();
    let range = volume.value_range();
    assert_eq!((range.min, range.max, range.non_finite_voxels), (1.0, 9.0, 2));
}

#[test]
fn refuses_wrong_sizes_zero_and_overflowing_dimensions() {
    let err = Volume::new(
        [2, 2, 2],
        [1.0; 3],
        VoxelType::U16,
        ByteOrder::Little,
        ValueScale::IDENTITY,
        VoxelBytes::Owned(vec![0; 15]),
        Path::new("t"),
    );
    assert!(matches!(err, Err(VolumeError::DataSize { expected: 16, found: 15, .. })));
    assert!(checked_voxel_count([0, 5, 5], VoxelType::U8, Path::new("t")).is_err());
    assert!(checked_voxel_count([usize::MAX / 2, 4, 1], VoxelType::U8, Path::new("t")).is_err());
}

#[test]
fn a_volume_without_a_finite_value_or_with_values_beyond_f32_is_refused() {
    let floats = |values: &[f32]| values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>();
    let new = |bytes: Vec<u8>, voxel_type, scale| {
        Volume::new([2, 1, 1], [1.0; 3], voxel_type, ByteOrder::Little, scale, VoxelBytes::Owned(bytes), Path::new("t"))
    };
    for values in [[f32::NAN, f32::NAN], [f32::INFINITY, f32::NEG_INFINITY], [f32::NAN, f32::INFINITY]] {
        let error = new(floats(&values), VoxelType::F32, ValueScale::IDENTITY).unwrap_err();
        assert!(matches!(error, VolumeError::NoFiniteValue { voxels: 2, .. }), "{values:?}: {error}");
    }
    let constant = new(floats(&[7.0, 7.0]), VoxelType::F32, ValueScale::IDENTITY).unwrap().value_range();
    assert_eq!((constant.min, constant.max), (7.0, 7.0), "a constant volume is readable");
    let doubles: Vec<u8> = [1.0f64, 1e39].iter().flat_map(|v| v.to_le_bytes()).collect();
    let error = new(doubles, VoxelType::F64, ValueScale::IDENTITY).unwrap_err();
    assert!(matches!(error, VolumeError::ValueOverflow { scaled: false, .. }), "{error}");
    let shorts: Vec<u8> = [3i16, 30000].iter().flat_map(|v| v.to_le_bytes()).collect();
    for (slope, intercept) in [(1e38, 0.0), (-1e38, 0.0), (1.0, -3.4e38 * 1.01)] {
        let error = new(shorts.clone(), VoxelType::I16, ValueScale { slope, intercept }).unwrap_err();
        assert!(matches!(error, VolumeError::ValueOverflow { scaled: true, .. }), "{slope} {intercept}: {error}");
        assert!(error.to_string().contains("after the file's value scaling"), "{error}");
    }
    let largest = new(shorts, VoxelType::I16, ValueScale { slope: 1e34, intercept: 0.0 }).unwrap().value_range();
    assert!(largest.max > 2.99e38 && largest.max <= f32::MAX as f64, "{}", largest.max);
}

#[test]
fn spacing_is_refused_outside_what_any_scan_has() {
    for value in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e30, 1e-30, 9.9e-5, 1.01e4] {
        for axis in 0..3 {
            let mut spacing = [1.0; 3];
            spacing[axis] = value;
            let error = check_spacing(spacing, Path::new("t")).unwrap_err();
            assert!(matches!(error, VolumeError::BadSpacing { axis: a, .. } if a == axis), "{value}: {error}");
            assert!(error.to_string().contains(["along x", "along y", "along z"][axis]), "{error}");
        }
    }
    assert!(check_spacing([SMALLEST_SPACING_MM, 1.0, LARGEST_SPACING_MM], Path::new("t")).is_ok());
    let as_f32 = |value: f64| value as f32 as f64;
    assert!(check_spacing([as_f32(SMALLEST_SPACING_MM), 1.0, as_f32(LARGEST_SPACING_MM)], Path::new("t")).is_ok());
    let error = check_spacing([1e30, 1.0, 1.0], Path::new("t")).unwrap_err().to_string();
    assert!(error.starts_with("voxel spacing 1e30 mm along x is outside 0.0001..10000 mm"), "{error}");
}
