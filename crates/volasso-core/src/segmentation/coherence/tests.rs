//! The majority filter: its passes against the rule voxel by voxel, at borders and the air, and with label bands.

use super::*;

/// One unbanded pass in the cube over `labels` (`dims`, x fastest); returns the voxels changed.
fn majority_pass(labels: &mut [u8], dims: [usize; 3]) -> usize {
    majority_passes(labels, dims, 1, None, Neighbourhood::Cube)
}

#[test]
fn an_isolated_voxel_joins_its_surroundings_and_background_stays() {
    let dims = [5, 5, 5];
    let mut labels = vec![1u8; 125];
    labels[62] = 2; // the centre
    labels[0] = 0;
    let changed = majority_pass(&mut labels, dims);
    assert_eq!(changed, 1);
    assert_eq!(labels[62], 1);
    assert_eq!(labels[0], 0, "background is never changed");
}

#[test]
fn a_flat_border_between_two_classes_stays_where_it_is() {
    // Half the block class 1, half class 2, split at x = 3: every voxel at the border has
    // 18 of its own and 9 of the other in its neighbourhood.
    let dims = [6, 4, 4];
    let mut labels: Vec<u8> = (0..96).map(|i| if i % 6 < 3 { 1 } else { 2 }).collect();
    let before = labels.clone();
    assert_eq!(majority_pass(&mut labels, dims), 0);
    assert_eq!(labels, before);
}

#[test]
fn a_class_next_to_the_air_is_not_eroded_by_it() {
    // A one-voxel-thick sheet of class 3 between air (0) and class 1: the air does not
    // vote, so the sheet has 9 votes of its own against 9 of class 1 and keeps its label.
    let dims = [5, 5, 5];
    let mut labels: Vec<u8> = (0..125).map(|i| [0, 0, 3, 1, 1][i % 5]).collect();
    assert_eq!(majority_pass(&mut labels, dims), 0);
    assert!(labels.iter().enumerate().all(|(i, &l)| l == [0, 0, 3, 1, 1][i % 5]));
}

/// The pass as the module doc states it, voxel by voxel, without any shortcut.
fn reference_pass(labels: &[u8], dims: [usize; 3]) -> Vec<u8> {
    reference_pass_allowing(labels, dims, |_, _, _, _| true)
}

/// The pass as the module doc states it, where `allowed(voxel, own, best, neighbourhood)`
/// says whether a voxel outvoted by `best` takes it (`neighbourhood`: its 3 x 3 x 3 labels
/// inside the volume, itself included).
fn reference_pass_allowing(labels: &[u8], dims: [usize; 3], allowed: impl Fn(usize, u8, u8, &[u8]) -> bool) -> Vec<u8> {
    let at = |x: usize, y: usize, z: usize| labels[(z * dims[1] + y) * dims[0] + x];
    let mut out = labels.to_vec();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let own = at(x, y, z);
                if own == 0 {
                    continue;
                }
                let mut counts = [0u32; 256];
                let mut seen = Vec::new();
                let mut neighbourhood = Vec::new();
                let mut face = false;
                for (dz, dy, dx) in (0..27).map(|i| (i / 9, i / 3 % 3, i % 3)) {
                    let (nx, ny, nz) = ((x + dx).wrapping_sub(1), (y + dy).wrapping_sub(1), (z + dz).wrapping_sub(1));
                    if nx >= dims[0] || ny >= dims[1] || nz >= dims[2] {
                        continue;
                    }
                    let label = at(nx, ny, nz);
                    neighbourhood.push(label);
                    if label != 0 {
                        if counts[label as usize] == 0 {
                            seen.push(label);
                        }
                        counts[label as usize] += 1;
                        face |= label != own && (dx == 1) as u8 + (dy == 1) as u8 + (dz == 1) as u8 == 2;
                    }
                }
                if face {
                    // Ties keep the label seen first (own before the others).
                    let mut best = own;
                    for &label in &seen {
                        if counts[label as usize] > counts[best as usize] {
                            best = label;
                        }
                    }
                    let voxel = (z * dims[1] + y) * dims[0] + x;
                    if best != own && allowed(voxel, own, best, &neighbourhood) {
                        out[voxel] = best;
                    }
                }
            }
        }
    }
    out
}

/// A label volume of `dims`: `block(x, y, z)`, except that where `speckled(x, y, z)` one voxel
/// in `one_in` (drawn from `seed`) takes a random label below `labels`, background included.
fn speckled_volume(
    dims: [usize; 3],
    seed: u64,
    one_in: u64,
    labels: u64,
    block: impl Fn(usize, usize, usize) -> u8,
    speckled: impl Fn(usize, usize, usize) -> bool,
) -> Vec<u8> {
    let mut rng = crate::rng::SplitMix64::new(seed);
    (0..dims[0] * dims[1] * dims[2])
        .map(|i| {
            let (x, y, z) = (i % dims[0], i / dims[0] % dims[1], i / (dims[0] * dims[1]));
            if speckled(x, y, z) && rng.next_u64() % one_in == 0 {
                (rng.next_u64() % labels) as u8
            } else {
                block(x, y, z)
            }
        })
        .collect()
}

/// A volume of up to four labels split at fixed fractions of x and y, every voxel speckled
/// (one in `2 + seed % densities`) with labels below `labels`, its width `3 + seed % widths`,
/// its height and depth from `seed` too; and its dims.
fn speckled_borders(seed: u64, widths: u64, densities: u64, labels: u64) -> ([usize; 3], Vec<u8>) {
    let dims = [3 + (seed % widths) as usize, 2 + (seed % 7) as usize, 1 + (seed % 5) as usize];
    let block = |x, y, _| 1 + u8::from(2 * x >= dims[0]) + u8::from(3 * y >= 2 * dims[1]);
    (dims, speckled_volume(dims, seed, 2 + seed % densities, labels, block, |_, _, _| true))
}

#[test]
fn the_pass_equals_the_voxel_by_voxel_rule_on_uniform_and_mixed_rows() {
    // Large uniform blocks (rows the shortcut skips), background, and speckle in plane 1 and
    // rows 6 up: the rows beside them in y and z are uniform and must still see it.
    let dims = [12, 9, 7];
    let block = |_, y, z| {
        if z < 3 {
            1
        } else if y < 4 {
            2
        } else {
            0
        }
    };
    let labels = speckled_volume(dims, 17, 5, 4, block, |_, y, z| z == 1 || y >= 6);
    let expected = reference_pass(&labels, dims);
    let mut labels = labels;
    majority_pass(&mut labels, dims);
    assert_eq!(labels, expected);
}

#[test]
fn the_pass_equals_the_voxel_by_voxel_rule_on_many_speckled_volumes() {
    // Borders between labels with speckle from sparse to dense: rows with few flagged voxels
    // count them label by label, rows with many first drop those their own label holds.
    for seed in 0..300u64 {
        let (dims, labels) = speckled_borders(seed, 17, 9, 5);
        let expected = reference_pass(&labels, dims);
        let mut passed = labels;
        majority_pass(&mut passed, dims);
        assert_eq!(passed, expected, "seed {seed}, dims {dims:?}");
    }
}

#[test]
fn passes_equal_single_passes_one_after_the_other() {
    let dims = [10, 8, 9];
    // Speckle in a few planes only, so later passes skip the others.
    let labels = speckled_volume(dims, 5, 3, 3, |x, _, _| 1 + u8::from(x >= 5), |_, _, z| z == 2 || z == 6);
    for passes in 1..=3 {
        let mut expected = labels.clone();
        let mut changed = 0;
        for _ in 0..passes {
            let after = reference_pass(&expected, dims);
            changed += after.iter().zip(&expected).filter(|(a, b)| a != b).count();
            expected = after;
        }
        let mut passed = labels.clone();
        assert_eq!(majority_passes(&mut passed, dims, passes, None, Neighbourhood::Cube), changed, "{passes} passes");
        assert_eq!(passed, expected, "{passes} passes");
    }
}

#[test]
fn a_uniform_row_outvoted_by_a_neighbouring_row_in_any_direction_changes() {
    // A line of class 1 in the air, along x at (y 2, z 2), beside a sheet of class 2 on one
    // side: 3 votes of its own against 9, in each of the four directions a row has
    // neighbours.
    let dims = [6, 5, 5];
    let index = |x: usize, y: usize, z: usize| (z * dims[1] + y) * dims[0] + x;
    for (dy, dz) in [(0, -1), (0, 1), (-1, 0), (1, 0)] {
        let mut labels = vec![0u8; dims.iter().product()];
        for x in 0..dims[0] {
            labels[index(x, 2, 2)] = 1;
            for offset in [-1, 0, 1] {
                let (y, z) = if dz != 0 { (2 + offset, 2 + dz) } else { (2 + dy, 2 + offset) };
                labels[index(x, y as usize, z as usize)] = 2;
            }
        }
        let expected = reference_pass(&labels, dims);
        assert!((0..dims[0]).all(|x| expected[index(x, 2, 2)] == 2), "({dy}, {dz})");
        majority_pass(&mut labels, dims);
        assert_eq!(labels, expected, "({dy}, {dz})");
    }
}

/// Bands per label, as [`LabelBands::new`] takes them.
type Bands = Vec<Option<(f32, f32)>>;

/// A 7 x 7 x 7 volume of label 1 at intensity 10 (band 0-20), with the given voxels set to a
/// label and an intensity; label 2's band is 180-220.
fn banded_scene(voxels: &[([usize; 3], u8, f32)]) -> (Vec<u8>, Vec<f32>, Bands) {
    let mut labels = vec![1u8; 343];
    let mut intensities = vec![10.0f32; 343];
    for &([x, y, z], label, intensity) in voxels {
        labels[x + 7 * (y + 7 * z)] = label;
        intensities[x + 7 * (y + 7 * z)] = intensity;
    }
    let mut bands = vec![None; 256];
    bands[1] = Some((0.0, 20.0));
    bands[2] = Some((180.0, 220.0));
    (labels, intensities, bands)
}

/// The majority filter's passes with `bands` over `labels` and `intensities`: the filtered
/// labels and the voxels changed.
fn filter_with_bands(labels: &[u8], intensities: &[f32], bands: Bands) -> (Vec<u8>, usize) {
    let intensity = |voxel: usize| intensities[voxel];
    let with_bands = LabelBands::new(bands, &intensity);
    let mut filtered = labels.to_vec();
    let changed = majority_passes(&mut filtered, [7, 7, 7], DEFAULT_PASSES, Some(&with_bands), Neighbourhood::Cube);
    (filtered, changed)
}

#[test]
fn with_bands_a_small_structure_unlike_its_surroundings_keeps_its_label() {
    // A bright cross of seven voxels: the majority alone votes it away.
    let cross = [[3, 3, 3], [2, 3, 3], [4, 3, 3], [3, 2, 3], [3, 4, 3], [3, 3, 2], [3, 3, 4]];
    let voxels: Vec<_> = cross.iter().map(|&at| (at, 2u8, 200.0f32)).collect();
    let (labels, intensities, bands) = banded_scene(&voxels);
    let mut plain = labels.clone();
    majority_passes(&mut plain, [7, 7, 7], DEFAULT_PASSES, None, Neighbourhood::Cube);
    assert!(plain.iter().all(|&label| label == 1), "without bands the cross is voted away");
    let (kept, changed) = filter_with_bands(&labels, &intensities, bands);
    assert_eq!(changed, 0);
    assert_eq!(kept, labels);
}

#[test]
fn with_bands_noisy_and_partial_volume_voxels_still_join_their_surroundings() {
    // Label 2 above z = 3. At z = 3: a voxel of label 2 as dark as label 1's band reaches (a
    // noisy one), and one of a third label halfway between the bands (a partial-volume one).
    let mut voxels = Vec::new();
    for z in 4..7 {
        for y in 0..7 {
            for x in 0..7 {
                voxels.push(([x, y, z], 2u8, 200.0f32));
            }
        }
    }
    voxels.push(([2, 3, 2], 2, 25.0));
    voxels.push(([4, 3, 3], 3, 100.0));
    let (labels, intensities, mut bands) = banded_scene(&voxels);
    bands[3] = Some((95.0, 105.0));
    let (filtered, _) = filter_with_bands(&labels, &intensities, bands);
    assert_eq!(filtered[2 + 7 * (3 + 7 * 2)], 1, "a noisy voxel within reach of its surroundings' band");
    assert_eq!(filtered[4 + 7 * (3 + 7 * 3)], 1, "a partial-volume voxel between its neighbours' bands");
    // In label 1: a voxel of label 2 as bright as its band (nothing around it could make it)
    // keeps its label; one far from both bands (its own label no surer than its neighbours')
    // joins them.
    let (labels, intensities, bands) = banded_scene(&[([3, 3, 1], 2, 200.0), ([3, 3, 5], 2, 100.0)]);
    let (filtered, _) = filter_with_bands(&labels, &intensities, bands);
    assert_eq!(filtered[3 + 7 * (3 + 7)], 2, "a voxel within its own band, unlike its surroundings");
    assert_eq!(filtered[3 + 7 * (3 + 7 * 5)], 1, "a voxel outside its own band");
}

/// [`banded_scene`] with label 2 at `intensity_of_sheet` on its plane z = 3.
fn sheet_scene(intensity_of_sheet: f32) -> (Vec<u8>, Vec<f32>, Bands) {
    let mut voxels = Vec::new();
    for y in 0..7 {
        for x in 0..7 {
            voxels.push(([x, y, 3], 2u8, intensity_of_sheet));
        }
    }
    banded_scene(&voxels)
}

#[test]
fn with_bands_a_sheet_one_voxel_thin_keeps_its_label() {
    // A sheet of label 2 holds 9 of each of its voxels' 27 neighbours, 4 of its 6 faces; a
    // 3 x 3 x 3 majority erases it. Its intensity is within label 1's widened band (a
    // partial-volume sheet, as the fluid in a brain's sulci), so the band rule alone would let
    // it go.
    let (labels, intensities, mut bands) = sheet_scene(25.0);
    bands[2] = Some((22.0, 40.0));
    let mut plain = labels.clone();
    majority_passes(&mut plain, [7, 7, 7], DEFAULT_PASSES, None, Neighbourhood::Cube);
    assert!(plain.iter().all(|&label| label == 1), "without bands the sheet is voted away");
    let (kept, _) = filter_with_bands(&labels, &intensities, bands);
    // Whatever happens at the volume's sides, the middle stays.
    let sheet = |x: usize, y: usize| kept[x + 7 * (y + 7 * 3)];
    assert!((2..5).all(|y| (2..5).all(|x| sheet(x, y) == 2)), "the sheet's middle keeps its label");
}

#[test]
fn with_bands_a_sheet_between_two_structures_or_outside_its_band_still_goes() {
    // A partial-volume shell: a 3 x 3 patch of label 3 (band 95-105) one voxel thin on the
    // plane z = 3, between label 1 (band 0-20, below and around it) and label 2 (band
    // 180-220, above), its intensity between theirs. Its middle voxel holds 4 of its faces.
    let mut voxels = Vec::new();
    for y in 0..7 {
        for x in 0..7 {
            if (2..5).contains(&x) && (2..5).contains(&y) {
                voxels.push(([x, y, 3], 3u8, 100.0f32));
            }
            for z in 4..7 {
                voxels.push(([x, y, z], 2u8, 200.0f32));
            }
        }
    }
    let (labels, intensities, mut bands) = banded_scene(&voxels);
    bands[3] = Some((95.0, 105.0));
    let (filtered, _) = filter_with_bands(&labels, &intensities, bands);
    assert!(!filtered.contains(&3), "the shell joins the structures on either side");
    // A sheet whose intensity its own band does not hold is not anchored.
    let (labels, intensities, mut bands) = sheet_scene(21.0);
    bands[2] = Some((22.0, 40.0));
    let (filtered, _) = filter_with_bands(&labels, &intensities, bands);
    assert!(filtered.iter().all(|&label| label == 1), "a sheet outside its own band joins its surroundings");
}

#[test]
fn with_bands_a_voxel_at_a_layer_s_edge_between_two_labels_only_around_it_keeps_its_label() {
    // Label 3 (band 95-105) at 100: the voxel (3, 3, 3) with its own label on its +x, +y and
    // +z faces, label 1 (band 0-20) on its -x and -y faces and label 2 (band 180-220) on its -z
    // face and below: the edge of a layer between the two, not a shell one voxel thick. The
    // 3 x 3 x 3 majority is label 1's.
    let mut voxels =
        vec![([3, 3, 3], 3u8, 100.0f32), ([4, 3, 3], 3, 100.0), ([3, 4, 3], 3, 100.0), ([3, 3, 4], 3, 100.0)];
    for y in 0..7 {
        for x in 0..7 {
            voxels.push(([x, y, 2], 2, 200.0));
        }
    }
    let (labels, intensities, mut bands) = banded_scene(&voxels);
    bands[3] = Some((95.0, 105.0));
    let (filtered, _) = filter_with_bands(&labels, &intensities, bands.clone());
    assert_eq!(filtered[3 + 7 * (3 + 7 * 3)], 3, "labels 1 and 2 only around it");
    // With label 1 on its +z face it lies between labels 2 and 1 along z: a shell, which goes.
    let mut sandwiched = voxels.clone();
    sandwiched[3] = ([3, 3, 4], 1, 10.0);
    let (labels, intensities, _) = banded_scene(&sandwiched);
    let (filtered, _) = filter_with_bands(&labels, &intensities, bands);
    assert_ne!(filtered[3 + 7 * (3 + 7 * 3)], 3, "labels 1 and 2 on opposite faces");
}

#[test]
fn with_bands_a_pair_of_voxels_its_intensity_speaks_for_keeps_its_label_and_a_single_one_goes() {
    // Label 2 at 25 (its band 22-40, within label 1's widened band: the band rule alone lets
    // it go), as the speckled fluid of a brain's sulci: a pair of voxels, each one face of
    // the other, and a single voxel apart from it.
    let voxels = [([2, 3, 3], 2u8, 25.0f32), ([3, 3, 3], 2, 25.0), ([5, 5, 1], 2, 25.0)];
    let (labels, intensities, mut bands) = banded_scene(&voxels);
    bands[2] = Some((22.0, 40.0));
    let (filtered, _) = filter_with_bands(&labels, &intensities, bands);
    assert_eq!((filtered[2 + 7 * (3 + 7 * 3)], filtered[3 + 7 * (3 + 7 * 3)]), (2, 2), "the pair stays");
    assert_eq!(filtered[5 + 7 * (5 + 7)], 1, "the single voxel joins its surroundings");
}

/// [`reference_pass_allowing`] with the bands' rule as the module doc states it: a voxel
/// whose intensity its own band holds takes another label only within the span of the widened
/// bands of its neighbourhood's other labels, and, when one of its six faces holds its own
/// label, only where `best`'s band holds it too, its own does not, or it lies between the band
/// centres of two labels on opposite faces of it. A label without a band holds any intensity.
fn reference_banded_pass(labels: &[u8], dims: [usize; 3], bands: &Bands, intensities: &[f32]) -> Vec<u8> {
    let holds = |label: u8, value: f32| bands[label as usize].is_some_and(|(low, high)| low <= value && value <= high);
    let face_offsets = |voxel: usize| {
        let (x, y, z) = (voxel % dims[0], voxel / dims[0] % dims[1], voxel / (dims[0] * dims[1]));
        let plane = dims[0] * dims[1];
        [
            (x > 0).then(|| voxel - 1),
            (x + 1 < dims[0]).then(|| voxel + 1),
            (y > 0).then(|| voxel - dims[0]),
            (y + 1 < dims[1]).then(|| voxel + dims[0]),
            (z > 0).then(|| voxel - plane),
            (z + 1 < dims[2]).then(|| voxel + plane),
        ]
    };
    reference_pass_allowing(labels, dims, |voxel, own, best, neighbourhood| {
        let value = intensities[voxel];
        let others: Vec<u8> = neighbourhood.iter().copied().filter(|&label| label != 0 && label != own).collect();
        let within_span = !holds(own, value) || others.iter().any(|&label| bands[label as usize].is_none()) || {
            let widened = |label: u8| {
                let (low, high) = bands[label as usize].unwrap_or((0.0, 0.0));
                let reach = PARTIAL_VOLUME_REACH * (high - low);
                (low - reach, high + reach)
            };
            let low = others.iter().map(|&label| widened(label).0).fold(f32::INFINITY, f32::min);
            let high = others.iter().map(|&label| widened(label).1).fold(f32::NEG_INFINITY, f32::max);
            low <= value && value <= high
        };
        let faces = face_offsets(voxel);
        let own_faces = faces.into_iter().flatten().filter(|&face| labels[face] == own).count();
        // Labels on opposite faces, both neither own nor background, and different.
        let sandwich: Vec<u8> = faces
            .chunks(2)
            .filter_map(|pair| Some((labels[pair[0]?], labels[pair[1]?])))
            .filter(|&(a, b)| a != b && ![a, b].iter().any(|&label| label == 0 || label == own))
            .flat_map(|(a, b)| [a, b])
            .collect();
        let centre = |label: u8| bands[label as usize].map(|(low, high)| (low + high) / 2.0);
        let released = own_faces < FACE_ANCHOR
            || !holds(own, value)
            || holds(best, value)
            || sandwich.iter().any(|&label| bands[label as usize].is_none())
            || (sandwich.iter().any(|&label| centre(label).is_some_and(|c| c <= value))
                && sandwich.iter().any(|&label| centre(label).is_some_and(|c| c >= value)));
        within_span && released
    })
}

#[test]
fn with_bands_the_pass_equals_the_voxel_by_voxel_rule_on_many_speckled_volumes() {
    // Up to five labels around each voxel, bands that overlap, leave gaps or are missing, and
    // intensities inside and outside them: every branch of the bands' rule, against the rule
    // written out voxel by voxel.
    for seed in 0..200u64 {
        let (dims, labels) = speckled_borders(seed, 13, 7, 6);
        let mut rng = crate::rng::SplitMix64::new(seed ^ 0x5eed);
        let mut bands: Bands = vec![None; 256];
        for band in bands.iter_mut().take(6).skip(1) {
            let low = (rng.next_u64() % 100) as f32;
            *band = (rng.next_u64() % 8 != 0).then_some((low, low + (rng.next_u64() % 40) as f32));
        }
        let intensities: Vec<f32> = labels.iter().map(|_| (rng.next_u64() % 150) as f32).collect();
        let expected = reference_banded_pass(&labels, dims, &bands, &intensities);
        let intensity = |voxel: usize| intensities[voxel];
        let with_bands = LabelBands::new(bands, &intensity);
        let mut passed = labels;
        majority_passes(&mut passed, dims, 1, Some(&with_bands), Neighbourhood::Cube);
        assert_eq!(passed, expected, "seed {seed}, dims {dims:?}");
    }
}

#[test]
fn a_plane_pass_is_the_pass_of_each_plane_on_its_own() {
    // Each z plane filtered as a volume one plane deep, the planes above and below unread;
    // dense speckle takes the rows that first drop the unbeatable voxels (5 of 9 votes).
    for seed in 0..200u64 {
        let (dims, labels) = speckled_borders(seed, 17, 9, 5);
        let plane = dims[0] * dims[1];
        for passes in [1, 2] {
            let mut expected = labels.clone();
            for z in 0..dims[2] {
                let mut one = expected[z * plane..][..plane].to_vec();
                for _ in 0..passes {
                    one = reference_pass(&one, [dims[0], dims[1], 1]);
                }
                expected[z * plane..][..plane].copy_from_slice(&one);
            }
            let mut passed = labels.clone();
            majority_passes(&mut passed, dims, passes, None, Neighbourhood::Plane);
            assert_eq!(passed, expected, "seed {seed}, dims {dims:?}, {passes} passes");
        }
    }
}

#[test]
fn a_sheet_one_slice_thick_is_voted_away_across_slices_but_not_within_them() {
    // A joint space one slice thick (label 2 at z = 2) between two bones (label 1): in the
    // 3 x 3 x 3 vote it holds 9 of 27, within its plane all 9.
    let dims = [6, 6, 5];
    let sheet: Vec<u8> = (0..180).map(|i| if i / 36 == 2 { 2 } else { 1 }).collect();
    let mut cube = sheet.clone();
    majority_passes(&mut cube, dims, DEFAULT_PASSES, None, Neighbourhood::Cube);
    assert!(cube.iter().all(|&label| label == 1), "the cube vote takes the sheet");
    let mut plane = sheet.clone();
    assert_eq!(majority_passes(&mut plane, dims, DEFAULT_PASSES, None, Neighbourhood::Plane), 0);
    assert_eq!(plane, sheet);
}

#[test]
fn slices_far_apart_against_their_pixels_vote_within_their_plane() {
    assert_eq!(Neighbourhood::for_spacing([1.0, 1.0, 1.0]), Neighbourhood::Cube);
    assert_eq!(Neighbourhood::for_spacing([0.8, 0.8, 2.5]), Neighbourhood::Cube);
    assert_eq!(Neighbourhood::for_spacing([0.45, 0.45, 5.0]), Neighbourhood::Plane);
    assert_eq!(Neighbourhood::for_spacing([0.5, 1.0, 3.6]), Neighbourhood::Plane, "the larger pixel side counts");
    assert_eq!(Neighbourhood::for_spacing([0.5, 1.0, 3.4]), Neighbourhood::Cube);
    assert_eq!(Neighbourhood::for_spacing([1.0, 1.0, 0.2]), Neighbourhood::Cube, "thin slices");
}
