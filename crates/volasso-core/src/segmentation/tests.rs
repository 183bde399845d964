//! What the spatial step's tests share: a scene of values and labels drawn by a function.

use crate::volume::Volume;
use std::path::Path;

/// The volume (1 mm voxels) and labels `voxel` gives at each (x, y, z) of `dims`: its value and
/// its label.
pub(super) fn scene(dims: [usize; 3], voxel: impl Fn(usize, usize, usize) -> (f32, u8)) -> (Volume, Vec<u8>) {
    let [size_x, size_y, size_z] = dims;
    let (mut values, mut labels) = (Vec::new(), Vec::new());
    for z in 0..size_z {
        for y in 0..size_y {
            for x in 0..size_x {
                let (value, label) = voxel(x, y, z);
                values.push(value);
                labels.push(label);
            }
        }
    }
    (Volume::from_f32(dims, [1.0; 3], &values, Path::new("scene")).unwrap(), labels)
}
