//! A voxel's neighbours in a volume of `dims` (x fastest): its six faces and its 3 x 3 x 3 cube,
//! the parts inside the volume.
//!
//! Never: reads values or labels.

/// The six face neighbours of `voxel` in pairs along x, y and z, `None` for a face outside the
/// volume.
pub(super) fn faces_of(voxel: usize, dims: [usize; 3]) -> [Option<usize>; 6] {
    let [size_x, size_y, size_z] = dims;
    let plane = size_x * size_y;
    let (x, y, z) = (voxel % size_x, voxel / size_x % size_y, voxel / plane);
    [
        (x > 0).then(|| voxel - 1),
        (x + 1 < size_x).then(|| voxel + 1),
        (y > 0).then(|| voxel - size_x),
        (y + 1 < size_y).then(|| voxel + size_x),
        (z > 0).then(|| voxel - plane),
        (z + 1 < size_z).then(|| voxel + plane),
    ]
}

/// The voxels of the 3 x 3 x 3 cube around `voxel` inside the volume, `voxel` itself included.
pub(super) fn cube_around(voxel: usize, dims: [usize; 3]) -> impl Iterator<Item = usize> {
    let [size_x, size_y, size_z] = dims;
    let (x, y, z) = (voxel % size_x, voxel / size_x % size_y, voxel / (size_x * size_y));
    let span = |at: usize, size: usize| at.saturating_sub(1)..(at + 2).min(size);
    span(z, size_z).flat_map(move |nz| {
        span(y, size_y).flat_map(move |ny| span(x, size_x).map(move |nx| nx + size_x * (ny + size_y * nz)))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corner_has_three_faces_and_a_cube_of_eight_and_an_inner_voxel_six_and_twenty_seven() {
        let dims = [4, 3, 5];
        let corner = 0;
        assert_eq!(faces_of(corner, dims), [None, Some(1), None, Some(4), None, Some(12)]);
        assert_eq!(cube_around(corner, dims).collect::<Vec<_>>(), vec![0, 1, 4, 5, 12, 13, 16, 17]);
        let inner = 1 + 4 * (1 + 3 * 2);
        assert_eq!(faces_of(inner, dims), [Some(28), Some(30), Some(25), Some(33), Some(17), Some(41)]);
        let cube: Vec<usize> = cube_around(inner, dims).collect();
        assert_eq!(cube.len(), 27);
        // x 0..=2, y 0..=2, z 1..=3: (0, 0, 1) is in it, (0, 0, 0) and (3, 1, 2) are not.
        assert!(cube.contains(&inner) && cube.contains(&12) && !cube.contains(&0) && !cube.contains(&(3 + 4 * 7)));
        let last = 4 * 3 * 5 - 1;
        assert_eq!(cube_around(last, dims).count(), 8);
        assert!(cube_around(last, dims).all(|voxel| voxel < 4 * 3 * 5));
    }
}
