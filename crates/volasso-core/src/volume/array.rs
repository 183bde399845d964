//! A volume's voxels as `ndarray` arrays, the shape in which a program embedding volasso hands
//! data in and takes it out.
//!
//! Arrays are indexed `[z, y, x]`, the order of the bytes in every file volasso reads (x varies
//! fastest), so a view over a memory map is the file itself, not a copy. A zero-copy view is
//! given only when it is exactly the stored values: the requested element type is the stored
//! type, the bytes are in the machine's order and suitably aligned. Otherwise the caller asks
//! for the physical values (rescale applied) as a converted `Array3<f32>`.
//!
//! Never: a view that silently reinterprets bytes (wrong type, foreign byte order), or a view of
//! rescaled values that are not the stored ones.

use std::path::Path;

use ndarray::{Array3, ArrayView3};

use super::{ByteOrder, Volume, VolumeError, VoxelType};

/// Element types a volume can be stored as; each names its [`VoxelType`].
pub trait StoredVoxel: bytemuck::Pod {
    /// The voxel type whose stored bytes are `Self` values.
    const VOXEL_TYPE: VoxelType;
}

macro_rules! stored_voxel {
    ($($t:ty => $v:ident),*) => {
        $(impl StoredVoxel for $t {
            const VOXEL_TYPE: VoxelType = VoxelType::$v;
        })*
    };
}

stored_voxel!(u8 => U8, i8 => I8, u16 => U16, i16 => I16, u32 => U32, i32 => I32, f32 => F32, f64 => F64);

/// The machine's byte order.
fn native_order() -> ByteOrder {
    if cfg!(target_endian = "little") { ByteOrder::Little } else { ByteOrder::Big }
}

impl Volume {
    /// The stored values as a view over the volume's bytes (a memory map for files), shape
    /// `[z, y, x]`, without copying. `None` when `T` is not the stored type, the bytes are in
    /// the other byte order or not aligned for `T`: use [`Volume::to_array_f32`] then.
    /// The values are the stored ones: apply [`Volume::scale`] for physical values.
    pub fn stored_view<T: StoredVoxel>(&self) -> Option<ArrayView3<'_, T>> {
        if T::VOXEL_TYPE != self.voxel_type {
            return None;
        }
        if self.voxel_type.size_bytes() > 1 && self.byte_order != native_order() {
            return None;
        }
        let values: &[T] = bytemuck::try_cast_slice(self.raw_bytes()).ok()?;
        let [nx, ny, nz] = self.dims;
        ArrayView3::from_shape((nz, ny, nx), values).ok()
    }

    /// The physical values (stored values with the rescale applied, NaN kept) as an owned
    /// `[z, y, x]` array of `f32`.
    pub fn to_array_f32(&self) -> Array3<f32> {
        let [nx, ny, nz] = self.dims;
        let mut values = vec![0.0f32; self.voxel_count()];
        self.read_f32(0, &mut values);
        Array3::from_shape_vec((nz, ny, nx), values).unwrap_or_else(|_| unreachable!("shape matches the voxel count"))
    }

    /// An in-memory volume holding `values` (indexed `[z, y, x]`) as `float32`, with the voxel
    /// spacing in millimetres along x, y, z. `name` stands for the volume in messages. Errors
    /// as [`Volume::new`] (an empty array, a spacing that is not finite and positive).
    pub fn from_array(values: ArrayView3<'_, f32>, spacing_mm: [f64; 3], name: &Path) -> Result<Volume, VolumeError> {
        let (nz, ny, nx) = values.dim();
        // `iter` walks in logical (z, y, x) order whatever the view's strides.
        let flat: Vec<f32> = values.iter().copied().collect();
        Volume::from_f32([nx, ny, nz], spacing_mm, &flat, name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::{ValueScale, VoxelBytes};
    use ndarray::s;

    fn volume_u16(order: ByteOrder, scale: ValueScale) -> Volume {
        let dims = [4usize, 3, 2];
        let values: Vec<u16> = (0..24u16).map(|v| v * 100).collect();
        let bytes: Vec<u8> = values
            .iter()
            .flat_map(|v| match order {
                ByteOrder::Little => v.to_le_bytes(),
                ByteOrder::Big => v.to_be_bytes(),
            })
            .collect();
        Volume::new(dims, [1.0, 1.0, 2.0], VoxelType::U16, order, scale, VoxelBytes::Owned(bytes), Path::new("t"))
            .expect("valid volume")
    }

    #[test]
    fn stored_view_indexes_z_y_x_without_copying() {
        let volume = volume_u16(native_order(), ValueScale::IDENTITY);
        let view = volume.stored_view::<u16>().expect("native u16 view");
        assert_eq!(view.dim(), (2, 3, 4));
        for (z, y, x) in [(0, 0, 0), (1, 2, 3), (0, 1, 2), (1, 0, 1)] {
            assert_eq!(f64::from(view[[z, y, x]]), volume.value_at(x, y, z));
        }
        assert_eq!(view.as_ptr().cast::<u8>(), volume.raw_bytes().as_ptr());
    }

    #[test]
    fn no_view_of_another_type_or_byte_order() {
        let volume = volume_u16(native_order(), ValueScale::IDENTITY);
        assert!(volume.stored_view::<i16>().is_none());
        assert!(volume.stored_view::<u8>().is_none());
        let foreign = if native_order() == ByteOrder::Little { ByteOrder::Big } else { ByteOrder::Little };
        assert!(volume_u16(foreign, ValueScale::IDENTITY).stored_view::<u16>().is_none());
    }

    #[test]
    fn converted_array_has_physical_values_in_any_byte_order() {
        let scale = ValueScale { slope: 0.5, intercept: -1024.0 };
        for order in [ByteOrder::Little, ByteOrder::Big] {
            let volume = volume_u16(order, scale);
            let array = volume.to_array_f32();
            assert_eq!(array.dim(), (2, 3, 4));
            for z in 0..2 {
                for y in 0..3 {
                    for x in 0..4 {
                        assert_eq!(f64::from(array[[z, y, x]]), volume.value_at(x, y, z));
                    }
                }
            }
        }
    }

    #[test]
    fn from_array_round_trips_and_follows_logical_order_of_strided_views() {
        let array = Array3::from_shape_fn((3, 4, 5), |(z, y, x)| (z * 100 + y * 10 + x) as f32);
        let volume = Volume::from_array(array.view(), [0.5, 0.5, 2.0], Path::new("array")).expect("volume");
        assert_eq!(volume.dims, [5, 4, 3]);
        assert_eq!(volume.to_array_f32(), array);
        // A reversed, strided view is copied in its logical order.
        let flipped = array.slice(s![..;-1, .., ..;2]);
        let volume = Volume::from_array(flipped, [1.0; 3], Path::new("flipped")).expect("volume");
        assert_eq!(volume.to_array_f32(), flipped.to_owned());
        assert!(Volume::from_array(Array3::<f32>::zeros((0, 2, 2)).view(), [1.0; 3], Path::new("empty")).is_err());
    }
}
