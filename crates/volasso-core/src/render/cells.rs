//! Label cells: for each cell of the label volume (the eight voxels `i..=i + 1` around a sample,
//! clamped at the far faces), its label when all eight agree, or [`MIXED_CELL`].
//!
//! Post-classification picks a sample's class from the eight labels around it
//! (`postclassified_sample` in `shaders/raycast.wgsl`). Away from class borders they all agree,
//! and one fetch of the cell's code gives the answer the eight fetches and the vote would give;
//! only cells on a border (or holding label 255, which shares the code) take the slow path. So
//! the cells never change a pixel, only the time.
//!
//! Cell `(x, y, z)` has its low corner at voxel `(x, y, z)`: the texture has the label volume's
//! size, and the shader uses it for samples whose low corner is inside the volume (the half-voxel
//! layer at the near faces takes the slow path).
//!
//! Never: keeps the codes on the CPU after the upload (they go up in z-slabs), or runs on the GPU.

use super::RenderError;
use super::volume_texture::{self, VolumeGeometry, VolumeTexture};
use rayon::prelude::*;

/// The code of a cell whose eight labels differ. WGSL twin: `MIXED_CELL`.
pub const MIXED_CELL: u8 = 255;

/// The codes of the cells with low corners in z-slices `slab`, x fastest.
pub fn cell_codes(dims: [usize; 3], labels: &[u8], slab: std::ops::Range<usize>) -> Vec<u8> {
    let [size_x, size_y, size_z] = dims;
    let plane = size_x * size_y;
    // The code of the 2x2 square with low corner (x, y) in slice z.
    let square = |z: usize, out: &mut [u8]| {
        let slice = &labels[z * plane..(z + 1) * plane];
        for y in 0..size_y {
            let next_y = (y + 1).min(size_y - 1);
            for x in 0..size_x {
                let next_x = (x + 1).min(size_x - 1);
                let label = slice[y * size_x + x];
                let same = slice[y * size_x + next_x] == label
                    && slice[next_y * size_x + x] == label
                    && slice[next_y * size_x + next_x] == label;
                out[y * size_x + x] = if same { label } else { MIXED_CELL };
            }
        }
    };
    let mut codes = vec![0u8; slab.len() * plane];
    codes.par_chunks_mut(plane).zip(slab).for_each_init(
        || vec![0u8; plane],
        |above, (out, z)| {
            square(z, out);
            square((z + 1).min(size_z - 1), above);
            for (code, above) in out.iter_mut().zip(above.iter()) {
                if *code != *above {
                    *code = MIXED_CELL;
                }
            }
        },
    );
    codes
}

/// Computes and uploads the cell codes of `labels` (a label volume of `geometry`), slab by slab.
pub fn upload_cells(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    geometry: VolumeGeometry,
    labels: &[u8],
) -> Result<VolumeTexture, RenderError> {
    let dims = geometry.dims;
    volume_texture::check_size("label volume", dims, geometry.voxel_count(), labels.len())?;
    let mut texture =
        volume_texture::create_texture(device, "label cells (R8Uint)", "label", dims, wgpu::TextureFormat::R8Uint)?;
    let plane = dims[0] * dims[1];
    let step = volume_texture::slices_per_slab(plane);
    for z in (0..dims[2]).step_by(step) {
        let slab = z..(z + step).min(dims[2]);
        let codes = cell_codes(dims, labels, slab.clone());
        volume_texture::write_slab(device, queue, &texture.texture, dims, 1, slab, &codes)?;
    }
    texture.geometry = geometry;
    Ok(texture)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_has_its_label_only_when_all_eight_corners_agree() {
        let dims = [5, 4, 3];
        let mut labels = vec![1u8; 60];
        labels[2 + 5 * (1 + 4)] = 2; // voxel (2, 1, 1)
        let codes = cell_codes(dims, &labels, 0..3);
        for z in 0..3 {
            for y in 0..4 {
                for x in 0..5 {
                    // Brute force: the eight clamped corners.
                    let mut corners = Vec::new();
                    for (dx, dy, dz) in (0..8).map(|c| (c & 1, (c >> 1) & 1, c >> 2)) {
                        let v = [(x + dx).min(4), (y + dy).min(3), (z + dz).min(2)];
                        corners.push(labels[v[0] + 5 * (v[1] + 4 * v[2])]);
                    }
                    let expected = if corners.iter().all(|&l| l == corners[0]) { corners[0] } else { MIXED_CELL };
                    assert_eq!(codes[x + 5 * (y + 4 * z)], expected, "cell ({x}, {y}, {z})");
                }
            }
        }
        // The eight cells whose corners include voxel (2, 1, 1) are mixed; the far faces clamp.
        assert_eq!(codes.iter().filter(|&&c| c == MIXED_CELL).count(), 8);
        assert_eq!(cell_codes(dims, &labels, 2..3), codes[40..].to_vec(), "a slab is the same as the whole");
    }
}
