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
