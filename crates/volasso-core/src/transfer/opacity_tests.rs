use super::*;
use crate::transfer::{ClassTable, HueTemplate, styles_from_statistics};
use std::path::Path;

/// A box of class 2 (`inner` voxels, inclusive bounds) inside a box of class 1 (`outer`),
/// in a background of 0.
fn nested_boxes(
    dims: [usize; 3],
    spacing_mm: [f64; 3],
    outer: [[usize; 2]; 3],
    inner: [[usize; 2]; 3],
) -> (Volume, Vec<u8>) {
    let inside = |b: [[usize; 2]; 3], v: [usize; 3]| (0..3).all(|a| (b[a][0]..=b[a][1]).contains(&v[a]));
    let mut labels = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                labels.push(if inside(inner, [x, y, z]) {
                    2
                } else if inside(outer, [x, y, z]) {
                    1
                } else {
                    0
                });
            }
        }
    }
    let values: Vec<f32> = labels.iter().map(|&l| l as f32).collect();
    (Volume::from_f32(dims, spacing_mm, &values, Path::new("boxes")).unwrap(), labels)
}

/// Faces between labels, counted by brute force over every voxel pair.
fn brute_force(dims: [usize; 3], spacing_mm: [f64; 3], labels: &[u8], classes: usize) -> Vec<ClassSurface> {
    let area = [spacing_mm[1] * spacing_mm[2], spacing_mm[0] * spacing_mm[2], spacing_mm[0] * spacing_mm[1]];
    let label_at = |v: [i64; 3]| -> u8 {
        if (0..3).all(|a| v[a] >= 0 && v[a] < dims[a] as i64) {
            labels[v[0] as usize + dims[0] * (v[1] as usize + dims[1] * v[2] as usize)]
        } else {
            0
        }
    };
    let mut surfaces = vec![ClassSurface { contact_area_mm2: vec![0.0; classes + 1], ..Default::default() }; classes];
    for z in 0..dims[2] as i64 {
        for y in 0..dims[1] as i64 {
            for x in 0..dims[0] as i64 {
                let label = label_at([x, y, z]);
                if label == 0 {
                    continue;
                }
                let surface = &mut surfaces[label as usize - 1];
                surface.volume_mm3 += spacing_mm.iter().product::<f64>();
                for axis in 0..3 {
                    for delta in [-1, 1] {
                        let mut neighbour = [x, y, z];
                        neighbour[axis] += delta;
                        let other = label_at(neighbour);
                        if other != label {
                            surface.surface_area_mm2 += area[axis];
                            surface.contact_area_mm2[other as usize] += area[axis];
                        }
                    }
                }
            }
        }
    }
    surfaces
}

#[test]
fn surfaces_match_a_brute_force_count_and_the_box_formulas() {
    let dims = [14, 12, 10];
    let spacing_mm = [0.5, 1.0, 2.0];
    let (volume, labels) = nested_boxes(dims, spacing_mm, [[1, 12], [1, 10], [1, 8]], [[4, 7], [3, 6], [2, 5]]);
    let surfaces = class_surfaces(&volume, &labels, 2, ClipBox::whole(dims).unwrap()).unwrap();
    let expected = brute_force(dims, spacing_mm, &labels, 2);
    for (found, expected) in surfaces.iter().zip(&expected) {
        assert!((found.volume_mm3 - expected.volume_mm3).abs() < 1e-9);
        assert!((found.surface_area_mm2 - expected.surface_area_mm2).abs() < 1e-9);
        for (f, e) in found.contact_area_mm2.iter().zip(&expected.contact_area_mm2) {
            assert!((f - e).abs() < 1e-9);
        }
    }
    // The inner box: 4 x 4 x 4 voxels = 2 x 4 x 8 mm, wrapped whole by class 1.
    let inner = &surfaces[1];
    assert_eq!(inner.volume_mm3, 64.0);
    assert_eq!(inner.surface_area_mm2, 2.0 * (2.0 * 4.0 + 2.0 * 8.0 + 4.0 * 8.0));
    assert_eq!(inner.exposure(), 0.0);
    assert!((inner.mean_chord_mm() - 4.0 * 64.0 / 112.0).abs() < 1e-12, "Cauchy: 4 V / S");
    assert_eq!(surfaces[0].contact_area_mm2[2], inner.surface_area_mm2, "what wraps the inner box is class 1");
    assert!(surfaces[0].exposure() > 0.5);
}

#[test]
fn the_clip_box_edge_counts_as_outside() {
    let dims = [10, 10, 10];
    let (volume, labels) = nested_boxes(dims, [1.0; 3], [[0, 9], [0, 9], [0, 9]], [[0, 0], [0, 0], [0, 0]]);
    let whole = class_surfaces(&volume, &labels, 2, ClipBox::whole(dims).unwrap()).unwrap();
    // The volume's faces are outside, less the three of the corner voxel of class 2.
    assert_eq!(whole[0].contact_area_mm2[0], 597.0);
    let half = ClipBox { lo: [0, 0, 0], hi: [4, 9, 9] };
    let clipped = class_surfaces(&volume, &labels, 2, half).unwrap();
    assert_eq!(clipped[0].volume_mm3, 499.0);
    assert_eq!(clipped[0].contact_area_mm2[0], 2.0 * (50.0 + 50.0 + 100.0) - 3.0, "the cut face is outside too");
}

#[test]
fn the_wrapping_class_is_see_through_and_each_wall_reaches_its_target() {
    let dims = [24, 24, 24];
    let (volume, labels) = nested_boxes(dims, [1.0; 3], [[2, 21], [2, 21], [2, 21]], [[8, 15], [8, 15], [8, 15]]);
    let surfaces = class_surfaces(&volume, &labels, 2, ClipBox::whole(dims).unwrap()).unwrap();
    let opacities = see_through_opacities(&surfaces, 1.0);
    let occlusion = occlusion(&surfaces);
    assert!(occlusion[0] > 0.0 && occlusion[1] == 0.0, "{occlusion:?}");
    assert!(opacities[0][0] < opacities[1][0], "the inner class is more opaque per step: {opacities:?}");
    // Across one mean chord, a ray accumulates the class's wall opacity.
    let across = |opacity: f32, surface: &ClassSurface| 1.0 - (1.0 - opacity as f64).powf(surface.mean_chord_mm());
    assert!((across(opacities[0][0], &surfaces[0]) - SEE_THROUGH_WRAPPING).abs() < 1e-6);
    assert!((across(opacities[1][0], &surfaces[1]) - SEE_THROUGH_WRAPPED).abs() < 1e-6);
    // Edges: eq. 9's factor 2 for what hides nothing, 3 for the strongest occluder.
    assert!((opacities[1][1] / opacities[1][0] - 2.0).abs() < 1e-6);
    assert!((opacities[0][1] / opacities[0][0] - 3.0).abs() < 1e-6);
    // Finer voxels (a smaller reference step) take a lower opacity per step for the same wall.
    let fine = see_through_opacities(&surfaces, 0.5);
    assert!(fine[0][0] < opacities[0][0]);
}

#[test]
fn a_lone_class_is_nearly_opaque_across_a_wall() {
    let dims = [16, 16, 16];
    let (volume, labels) = nested_boxes(dims, [1.0; 3], [[4, 11], [4, 11], [4, 11]], [[0, 0], [0, 0], [0, 0]]);
    let labels: Vec<u8> = labels.iter().map(|&l| l.min(1)).collect();
    let surfaces = class_surfaces(&volume, &labels, 1, ClipBox::whole(dims).unwrap()).unwrap();
    let [inside, edge] = see_through_opacities(&surfaces, 1.0)[0];
    let across = 1.0 - (1.0 - inside as f64).powf(surfaces[0].mean_chord_mm());
    assert!((across - SEE_THROUGH_WRAPPED).abs() < 1e-6);
    assert!((edge / inside - 2.0).abs() < 1e-6);
}

#[test]
fn tables_use_the_see_through_rule_by_default_and_keep_eq_9_on_request() {
    let dims = [24, 24, 24];
    let (volume, labels) = nested_boxes(dims, [1.0; 3], [[2, 21], [2, 21], [2, 21]], [[8, 15], [8, 15], [8, 15]]);
    let template = HueTemplate::default_for(2);
    let default = ClassTable::compute(&volume, &labels, 2, template).unwrap();
    assert_eq!(default.opacity_rule, OpacityRule::SeeThrough);
    let surfaces = class_surfaces(&volume, &labels, 2, ClipBox::whole(dims).unwrap()).unwrap();
    let opacities: Vec<[f32; 2]> = default.styles.iter().map(|s| s.opacity).collect();
    assert_eq!(opacities, see_through_opacities(&surfaces, 1.0));

    let paper = ClassTable::compute_with_rule(&volume, &labels, 2, template, OpacityRule::Paper).unwrap();
    let statistics = crate::transfer::class_statistics(&volume, &labels, 2, ClipBox::whole(dims).unwrap()).unwrap();
    assert_eq!(paper.styles, styles_from_statistics(&statistics, &template));
    // Only the opacities differ between the rules.
    for (a, b) in default.styles.iter().zip(&paper.styles) {
        assert_eq!((a.hue_degrees, a.saturation, a.value), (b.hue_degrees, b.saturation, b.value));
    }
    let json = serde_json::to_string(&default).unwrap();
    assert!(json.contains(r#""opacity_rule":"see-through""#), "{json}");
}
