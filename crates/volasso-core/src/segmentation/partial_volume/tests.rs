//! Partial-volume layers: a one-voxel shell of a middle class round a bright blob goes to the
//! blob and its surroundings, a sheet of it between two tissues too; the class's drawn piece, a
//! thin class's thin pieces, a thin piece inside one tissue and a tissue two voxels thick stay.

use super::*;
use crate::segmentation::tests::scene;

const DIMS: [usize; 3] = [30, 20, 20];

/// Medium (class 1, 40) everywhere; a thick cell (class 2, 105) at x < 10, lassoed at its middle;
/// a bright granule (class 3, 250) round (22, 10, 10) of radius 2, with its one-voxel blurred
/// shell at 145 that the classifier called cell.
fn granule_scene(shell_label: u8) -> (Volume, Vec<u8>, Vec<(usize, u8)>) {
    let [size_x, size_y, _] = DIMS;
    let (volume, labels) = scene(DIMS, |x, y, z| {
        let distance = ((x as f32 - 22.0).powi(2) + (y as f32 - 10.0).powi(2) + (z as f32 - 10.0).powi(2)).sqrt();
        if x < 10 {
            (105.0, 2)
        } else if distance <= 2.0 {
            (250.0, 3)
        } else if distance <= 3.0 {
            (145.0, shell_label)
        } else {
            (40.0, 1)
        }
    });
    let at = |x: usize, y: usize, z: usize| x + size_x * (y + size_y * z);
    let lassoed = vec![(at(5, 10, 10), 2), (at(15, 3, 3), 1), (at(22, 10, 10), 3)];
    (volume, labels, lassoed)
}

#[test]
fn a_middle_class_s_shell_round_a_bright_blob_goes_to_the_blob_and_its_surroundings() {
    let (volume, mut labels, lassoed) = granule_scene(2);
    let shell: Vec<usize> = (0..labels.len()).filter(|&v| labels[v] == 2 && v % DIMS[0] >= 10).collect();
    assert!(shell.len() > 50);
    let changed = settle_layers(&volume, &mut labels, &lassoed);
    assert_eq!(changed, shell.len());
    // 145 lies 105 from both the medium's 40 and the granule's 250: each voxel takes one of
    // its neighbours' classes, and none stays a cell.
    assert!(shell.iter().all(|&v| labels[v] == 1 || labels[v] == 3));
    // The drawn cell is untouched.
    assert!((0..labels.len()).filter(|&v| v % DIMS[0] < 10).all(|v| labels[v] == 2));
}

#[test]
fn a_shell_a_loop_touches_stays() {
    let (volume, mut labels, mut lassoed) = granule_scene(2);
    // A loop drawn on the shell's largest piece: the user said it is a cell.
    let (piece_of, pieces) = pieces(&labels, DIMS, &[false, true, true, true]);
    let largest = (0..pieces.len())
        .filter(|&p| pieces[p].label == 2 && pieces[p].size < 1000)
        .max_by_key(|&p| pieces[p].size)
        .unwrap();
    let piece: Vec<usize> = (0..labels.len()).filter(|&v| piece_of[v] as usize == largest).collect();
    assert!(piece.len() >= 8 && pieces[largest].interior == 0, "{}", piece.len());
    lassoed.push((piece[0], 2));
    settle_layers(&volume, &mut labels, &lassoed);
    assert!(piece.iter().all(|&v| labels[v] == 2));
}

#[test]
fn a_thin_class_keeps_its_thin_pieces() {
    // The class drawn is itself thin, like a joint space: a slab two voxels thick (class 2 at
    // 105, x < 10 and 4 <= y < 6, lassoed) with one short stretch three voxels thick, so that a
    // few of its voxels are interior; the shell round the granule is labelled with it.
    let (volume, mut labels, _) = granule_scene(2);
    let [size_x, size_y, size_z] = DIMS;
    for x in 0..10 {
        for y in 0..size_y {
            for z in 0..size_z {
                let slab = (4..6).contains(&y) || (y == 6 && (3..6).contains(&x) && (3..6).contains(&z));
                labels[x + size_x * (y + size_y * z)] = if slab { 2 } else { 1 };
            }
        }
    }
    let interior = (0..labels.len())
        .filter(|&v| labels[v] == 2 && v % size_x < 10)
        .filter(|&v| faces_of(v, DIMS).iter().all(|face| face.is_none_or(|face| labels[face] == 2)))
        .count();
    assert!(interior > 0);
    let lassoed = vec![(5 + size_x * (4 + size_y * 4), 2), (22 + size_x * (10 + size_y * 10), 3)];
    let before = labels.clone();
    assert_eq!(settle_layers(&volume, &mut labels, &lassoed), 0);
    assert_eq!(labels, before);
}

#[test]
fn a_thin_piece_inside_one_tissue_stays() {
    // The shell's class lies above the medium and below nothing else: with the granule labelled
    // medium too, the shell touches one class only and is a structure of its own, not a border.
    let (volume, mut labels, lassoed) = granule_scene(2);
    for label in labels.iter_mut().filter(|label| **label == 3) {
        *label = 1;
    }
    let lassoed: Vec<(usize, u8)> = lassoed.into_iter().filter(|&(_, class)| class != 3).collect();
    let before = labels.clone();
    assert_eq!(settle_layers(&volume, &mut labels, &lassoed), 0);
    assert_eq!(labels, before);
}

/// Fat (class 1, -100) at x < 12, muscle (class 2, 50) beyond the layer at x = 12 (and 13 when
/// `thickness` is 2) at -20, which the classifier called lesion (class 3, 10); the lesion is
/// drawn as a thick ball elsewhere inside the muscle.
fn sheet_scene(thickness: usize) -> (Volume, Vec<u8>, Vec<(usize, u8)>) {
    let [size_x, size_y, _] = DIMS;
    let (volume, labels) = scene(DIMS, |x, y, z| {
        let in_lesion = (x as f32 - 22.0).powi(2) + (y as f32 - 10.0).powi(2) + (z as f32 - 10.0).powi(2) <= 9.0;
        match x {
            _ if in_lesion => (10.0, 3),
            _ if x < 12 => (-100.0, 1),
            _ if x < 12 + thickness => (-20.0, 3),
            _ => (50.0, 2),
        }
    });
    let lassoed = vec![(22 + size_x * (10 + size_y * 10), 3), (3, 1), (size_x - 1, 2)];
    (volume, labels, lassoed)
}

#[test]
fn a_sheet_between_two_tissues_goes_to_them() {
    let (volume, mut labels, lassoed) = sheet_scene(1);
    let [size_x, size_y, size_z] = DIMS;
    let changed = settle_layers(&volume, &mut labels, &lassoed);
    assert_eq!(changed, size_y * size_z);
    for v in (0..labels.len()).filter(|v| v % size_x == 12) {
        // -20 is 80 from the fat's -100 and 70 from the muscle's 50.
        assert_eq!(labels[v], 2, "voxel {v}");
    }
    let lesion = (0..labels.len()).filter(|&v| volume.value(v) == 10.0).count();
    assert_eq!(labels.iter().filter(|&&label| label == 3).count(), lesion);
}

#[test]
fn a_tissue_two_voxels_thick_between_two_others_stays() {
    // Like the CSF round a brain, drawn in the ventricles only: two voxels across, it has no
    // interior, but it is a tissue of its own, not a border's blur.
    let (volume, mut labels, lassoed) = sheet_scene(2);
    let before = labels.clone();
    assert_eq!(settle_layers(&volume, &mut labels, &lassoed), 0);
    assert_eq!(labels, before);
}
