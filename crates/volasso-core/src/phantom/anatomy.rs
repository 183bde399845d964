//! The demo foot's anatomy: signed-distance shapes in millimetres, and the tissue at a point.
//!
//! Coordinates: x runs heel to toes, y medial (big toe) to lateral, z sole to ankle, in a
//! 153.6 x 102.4 x 115.2 mm field of view. Signed distances are negative inside a shape.
//! The skin is a smooth union of blobs (leg, heel, midfoot, forefoot, toes). Bones are
//! capsules and ellipsoids that overlap where they articulate; where two overlap, the voxel
//! goes to the bone it lies deeper in, and a slab of [`JOINT_GAP_MM`] around the equal-depth
//! surface is joint space (cartilage and fluid). Each bone has a dense cortex of its own
//! thickness, also along its joint surfaces (the subchondral plate), around cancellous marrow.

/// Field of view in mm (x, y, z): 192 x 128 x 96 voxels of 0.8 x 0.8 x 1.2 mm.
pub const FIELD_OF_VIEW_MM: [f64; 3] = [153.6, 102.4, 115.2];
/// Thickness of joint space between articulating bones.
pub const JOINT_GAP_MM: f64 = 2.4;
/// Subcutaneous fat under the skin.
pub const FAT_THICKNESS_MM: f64 = 2.4;
/// Radius of the smooth union that blends the skin blobs.
const SKIN_BLEND_MM: f64 = 10.0;

/// Tissue classes of the ground truth (index = class id; 0 is air).
pub const CLASS_NAMES: [&str; 4] = ["air", "soft tissue", "bone", "joint"];
/// Class id of air around the foot.
pub const AIR: u8 = 0;
/// Class id of fat and muscle.
pub const SOFT_TISSUE: u8 = 1;
/// Class id of cortex and marrow.
pub const BONE: u8 = 2;
/// Class id of the joint spaces between bones.
pub const JOINT: u8 = 3;

/// Hounsfield units before blur and noise.
/// Air, in HU.
pub const AIR_HU: f32 = -1000.0;
/// Subcutaneous fat, in HU.
pub const FAT_HU: f32 = -90.0;
/// Muscle and the rest of the soft tissue, in HU.
pub const MUSCLE_HU: f32 = 40.0;
/// Joint space (cartilage and fluid), in HU.
pub const JOINT_HU: f32 = 105.0;

/// A primitive with an exact or near-exact signed distance.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// Points within `radius` of the segment `from`-`to`.
    Capsule {
        /// One end of the segment, in mm.
        from: [f64; 3],
        /// The other end, in mm.
        to: [f64; 3],
        /// In mm.
        radius: f64,
    },
    /// Axis-aligned ellipsoid (distance approximated, exact on the axes).
    Ellipsoid {
        /// In mm.
        centre: [f64; 3],
        /// Semi-axes along x, y and z, in mm.
        radii: [f64; 3],
    },
}

impl Shape {
    /// Distance from point `p` (mm) to the surface, in mm: negative inside.
    pub fn signed_distance_mm(&self, p: [f64; 3]) -> f64 {
        match *self {
            Shape::Capsule { from, to, radius } => {
                let axis = sub(to, from);
                let offset = sub(p, from);
                let t = (dot(offset, axis) / dot(axis, axis)).clamp(0.0, 1.0);
                let closest = [from[0] + t * axis[0], from[1] + t * axis[1], from[2] + t * axis[2]];
                norm(sub(p, closest)) - radius
            }
            Shape::Ellipsoid { centre, radii } => {
                let q = sub(p, centre);
                let scaled = [q[0] / radii[0], q[1] / radii[1], q[2] / radii[2]];
                let scaled2 = [scaled[0] / radii[0], scaled[1] / radii[1], scaled[2] / radii[2]];
                let k0 = norm(scaled);
                let k1 = norm(scaled2);
                if k1 < 1e-12 { -radii[0].min(radii[1]).min(radii[2]) } else { k0 * (k0 - 1.0) / k1 }
            }
        }
    }

    /// The shape's bounding box grown by `margin_mm`: (low corner, high corner).
    pub fn bounds_mm(&self, margin_mm: f64) -> ([f64; 3], [f64; 3]) {
        match *self {
            Shape::Capsule { from, to, radius } => (
                std::array::from_fn(|a| from[a].min(to[a]) - radius - margin_mm),
                std::array::from_fn(|a| from[a].max(to[a]) + radius + margin_mm),
            ),
            Shape::Ellipsoid { centre, radii } => (
                std::array::from_fn(|a| centre[a] - radii[a] - margin_mm),
                std::array::from_fn(|a| centre[a] + radii[a] + margin_mm),
            ),
        }
    }
}

/// A bone: its shape, cortex thickness and densities.
#[derive(Clone, Copy, Debug)]
pub struct Bone {
    /// The bone's anatomical name.
    pub name: &'static str,
    /// Its outer surface.
    pub shape: Shape,
    /// Thickness of the cortical shell, in mm.
    pub cortex_mm: f64,
    /// Density of the cortex, in HU.
    pub cortex_hu: f32,
    /// Density of the marrow inside, in HU.
    pub marrow_hu: f32,
}

const fn capsule(from: [f64; 3], to: [f64; 3], radius: f64) -> Shape {
    Shape::Capsule { from, to, radius }
}

const fn ellipsoid(centre: [f64; 3], radii: [f64; 3]) -> Shape {
    Shape::Ellipsoid { centre, radii }
}

const fn bone(name: &'static str, shape: Shape, cortex_mm: f64, cortex_hu: f32, marrow_hu: f32) -> Bone {
    Bone { name, shape, cortex_mm, cortex_hu, marrow_hu }
}

/// The skin: blobs blended by a smooth union.
#[rustfmt::skip]
pub const SKIN: [Shape; 9] = [
    capsule([40.0, 54.0, 60.0], [40.0, 54.0, 175.0], 25.0), // leg
    ellipsoid([32.0, 54.0, 34.0], [26.0, 24.0, 26.0]),      // heel
    ellipsoid([74.0, 52.0, 31.0], [34.0, 30.0, 20.0]),      // midfoot
    ellipsoid([110.0, 49.0, 20.0], [22.0, 33.0, 12.0]),     // forefoot
    capsule([126.0, 29.0, 18.0], [144.0, 26.0, 16.0], 8.5), // big toe
    capsule([126.0, 42.0, 16.0], [139.0, 41.0, 14.0], 6.0),
    capsule([124.0, 52.0, 15.0], [135.0, 52.0, 13.0], 5.5),
    capsule([120.0, 61.0, 14.0], [130.0, 62.0, 12.0], 5.5),
    capsule([113.0, 71.0, 13.0], [123.0, 73.0, 11.0], 5.0), // little toe
];

/// The bones (a simplified right foot and the distal leg): name, shape, cortex thickness (mm),
/// cortex and marrow HU.
#[rustfmt::skip]
pub const BONES: [Bone; 22] = [
    bone("tibia", capsule([42.0, 54.0, 60.0], [42.0, 54.0, 200.0], 12.0), 2.6, 1450.0, 300.0),
    bone("fibula", capsule([40.0, 75.0, 50.0], [38.0, 74.0, 200.0], 5.5), 1.8, 1400.0, 320.0),
    bone("talus", ellipsoid([46.0, 54.0, 44.0], [17.0, 14.0, 10.0]), 1.4, 1250.0, 280.0),
    bone("calcaneus", ellipsoid([32.0, 56.0, 28.0], [26.0, 14.0, 11.0]), 1.4, 1200.0, 250.0),
    bone("navicular", ellipsoid([66.0, 46.0, 42.0], [6.5, 12.0, 8.0]), 1.2, 1250.0, 300.0),
    bone("cuboid", ellipsoid([62.0, 62.0, 28.0], [9.0, 9.0, 8.0]), 1.2, 1200.0, 290.0),
    bone("medial cuneiform", ellipsoid([78.0, 36.0, 38.0], [7.0, 6.0, 8.0]), 1.2, 1250.0, 310.0),
    bone("intermediate cuneiform", ellipsoid([78.0, 47.0, 38.0], [7.0, 5.0, 8.0]), 1.2, 1250.0, 310.0),
    bone("lateral cuneiform", ellipsoid([77.0, 57.0, 35.0], [7.0, 5.0, 8.0]), 1.2, 1250.0, 310.0),
    bone("metatarsal 1", capsule([88.0, 34.0, 33.0], [118.0, 29.0, 20.0], 5.5), 1.6, 1350.0, 330.0),
    bone("metatarsal 2", capsule([89.0, 46.0, 33.0], [122.0, 42.0, 18.0], 4.0), 1.5, 1350.0, 340.0),
    bone("metatarsal 3", capsule([88.0, 56.0, 31.0], [119.0, 52.0, 17.0], 3.8), 1.5, 1350.0, 340.0),
    bone("metatarsal 4", capsule([84.0, 64.0, 29.0], [115.0, 61.0, 16.0], 3.8), 1.5, 1350.0, 340.0),
    bone("metatarsal 5", capsule([74.0, 70.0, 26.0], [109.0, 71.0, 14.0], 4.0), 1.5, 1350.0, 340.0),
    bone("proximal phalanx 1", capsule([127.0, 28.0, 18.5], [134.0, 27.0, 17.0], 4.6), 1.3, 1300.0, 330.0),
    bone("distal phalanx 1", capsule([140.0, 26.5, 16.0], [144.0, 26.0, 15.5], 4.0), 1.3, 1300.0, 330.0),
    bone("proximal phalanx 2", capsule([128.0, 41.5, 16.0], [134.0, 41.0, 15.0], 3.2), 1.2, 1300.0, 330.0),
    bone("proximal phalanx 3", capsule([125.0, 51.8, 15.0], [131.0, 51.8, 14.0], 3.0), 1.2, 1300.0, 330.0),
    bone("proximal phalanx 4", capsule([121.0, 61.2, 14.0], [127.0, 61.6, 13.0], 3.0), 1.2, 1300.0, 330.0),
    bone("proximal phalanx 5", capsule([115.0, 71.6, 13.0], [120.0, 72.4, 12.0], 2.9), 1.2, 1300.0, 330.0),
    bone("sesamoid medial", ellipsoid([116.0, 25.0, 12.5], [3.0, 2.5, 2.5]), 1.0, 1300.0, 350.0),
    bone("sesamoid lateral", ellipsoid([116.0, 32.0, 12.5], [3.0, 2.5, 2.5]), 1.0, 1300.0, 350.0),
];

/// Polynomial smooth minimum (blends within `k`).
fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - h * h * k * 0.25
}

/// Shapes to consider for one row of voxels (fixed y and z), culled by bounding box.
pub struct RowShapes {
    /// Indices into [`SKIN`] and [`BONES`] whose grown bounds meet the row, with their x range.
    skin: Vec<(usize, f64, f64)>,
    bones: Vec<(usize, f64, f64)>,
}

/// Margins that keep culling exact where it matters: a skin blob farther than this from a
/// point cannot change whether the point is inside or within the fat layer; a bone farther
/// than this cannot change the joint, cortex or marrow decision.
const SKIN_MARGIN_MM: f64 = 1.25 * SKIN_BLEND_MM + FAT_THICKNESS_MM + 1.0;
// 2.6 mm is the thickest cortex (tibia).
const BONE_MARGIN_MM: f64 = JOINT_GAP_MM + 2.0 * 2.6 + 1.0;

impl RowShapes {
    /// The shapes that can matter on the row at `y_mm`, `z_mm`.
    pub fn for_row(y_mm: f64, z_mm: f64) -> RowShapes {
        let meets = |shape: &Shape, margin: f64| {
            let (low, high) = shape.bounds_mm(margin);
            (low[1] <= y_mm && y_mm <= high[1] && low[2] <= z_mm && z_mm <= high[2]).then_some((low[0], high[0]))
        };
        RowShapes {
            skin: SKIN
                .iter()
                .enumerate()
                .filter_map(|(k, s)| meets(s, SKIN_MARGIN_MM).map(|(a, b)| (k, a, b)))
                .collect(),
            bones: BONES
                .iter()
                .enumerate()
                .filter_map(|(k, b)| meets(&b.shape, BONE_MARGIN_MM).map(|(a, c)| (k, a, c)))
                .collect(),
        }
    }

    /// Whether the row misses the skin (all air).
    pub fn is_empty(&self) -> bool {
        self.skin.is_empty()
    }

    /// Visits the tissue at points x = 0, 1, ..., `count` - 1 voxels of `step_mm` along this
    /// row. Distances bound how far nothing can change (a signed distance changes by at most
    /// the distance moved; half of that is assumed, for the approximate ellipsoid distance),
    /// so runs of air, and of soft tissue away from bone, are passed without evaluating shapes.
    pub fn walk(
        &self,
        y_mm: f64,
        z_mm: f64,
        step_mm: f64,
        count: usize,
        mut visit: impl FnMut(usize, [f64; 3], Tissue),
    ) {
        let skip = |distance: f64, margin: f64| (0.5 * distance.min(margin) / step_mm) as usize;
        let mut air_until = 0;
        let mut boneless_until = 0;
        for x in 0..count {
            let p = [x as f64 * step_mm, y_mm, z_mm];
            if x < air_until {
                visit(x, p, Tissue::Air);
                continue;
            }
            let skin = self.skin_distance_mm(p);
            if skin > 0.0 {
                air_until = x + 1 + skip(skin, SKIN_MARGIN_MM);
                visit(x, p, Tissue::Air);
                continue;
            }
            let tissue = if x < boneless_until {
                soft_tissue(skin)
            } else {
                let (nearest, bone, second) = self.bone_distances_mm(p);
                if nearest >= 0.0 {
                    boneless_until = x + 1 + skip(nearest, BONE_MARGIN_MM);
                    soft_tissue(skin)
                } else {
                    bone_tissue(nearest, bone, second)
                }
            };
            visit(x, p, tissue);
        }
    }

    /// The tissue at one point (mm).
    pub fn tissue_at(&self, p: [f64; 3]) -> Tissue {
        let skin = self.skin_distance_mm(p);
        if skin > 0.0 {
            return Tissue::Air;
        }
        let (nearest, bone, second) = self.bone_distances_mm(p);
        if nearest < 0.0 { bone_tissue(nearest, bone, second) } else { soft_tissue(skin) }
    }

    /// Signed distance to the skin (smooth union of the blobs whose bounds hold `p`); infinite
    /// where none does.
    fn skin_distance_mm(&self, p: [f64; 3]) -> f64 {
        let mut skin = f64::INFINITY;
        for &(k, low, high) in &self.skin {
            if low <= p[0] && p[0] <= high {
                let d = SKIN[k].signed_distance_mm(p);
                skin = if skin.is_finite() { smooth_min(skin, d, SKIN_BLEND_MM) } else { d };
            }
        }
        skin
    }

    /// The nearest bone's distance and index, and the second-nearest bone's distance.
    fn bone_distances_mm(&self, p: [f64; 3]) -> (f64, usize, f64) {
        let (mut nearest, mut nearest_bone, mut second) = (f64::INFINITY, usize::MAX, f64::INFINITY);
        for &(k, low, high) in &self.bones {
            if low <= p[0] && p[0] <= high {
                let d = BONES[k].shape.signed_distance_mm(p);
                if d < nearest {
                    second = nearest;
                    nearest = d;
                    nearest_bone = k;
                } else if d < second {
                    second = d;
                }
            }
        }
        (nearest, nearest_bone, second)
    }
}

/// Inside bone `bone` (`nearest` < 0): joint space near another bone, else cortex or marrow.
fn bone_tissue(nearest: f64, bone: usize, second: f64) -> Tissue {
    let to_neighbour = second - nearest;
    if to_neighbour < JOINT_GAP_MM {
        return Tissue::Joint;
    }
    // Depth below the nearer of the outer surface and the joint surface; the depth from the
    // joint surface grows at half the rate of the distance difference.
    let depth = (-nearest).min((to_neighbour - JOINT_GAP_MM) / 2.0);
    if depth < BONES[bone].cortex_mm { Tissue::Cortex(bone) } else { Tissue::Marrow(bone) }
}

/// Inside the skin, outside bone.
fn soft_tissue(skin: f64) -> Tissue {
    if skin > -FAT_THICKNESS_MM { Tissue::Fat } else { Tissue::Muscle }
}

/// What a point is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tissue {
    /// Outside the skin.
    Air,
    /// Within [`FAT_THICKNESS_MM`] under the skin.
    Fat,
    /// Deeper soft tissue.
    Muscle,
    /// Inside a bone but near another: the joint space between them.
    Joint,
    /// The cortical shell of the bone at this index in [`BONES`].
    Cortex(usize),
    /// The marrow of the bone at this index in [`BONES`].
    Marrow(usize),
}

impl Tissue {
    /// The ground-truth class a clinician would lasso.
    pub fn class(self) -> u8 {
        match self {
            Tissue::Air => AIR,
            Tissue::Fat | Tissue::Muscle => SOFT_TISSUE,
            Tissue::Joint => JOINT,
            Tissue::Cortex(_) | Tissue::Marrow(_) => BONE,
        }
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
