//! Per-frame render settings: which classification, sampling, shading, clipping (a box and a
//! plane) and background; checked once by [`RenderSettings::validate`] before they reach the GPU.
//!
//! Never: holds volume data or camera pose (see [`super::Camera`]).

use super::RenderError;

/// Where colour and opacity come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RenderMode {
    /// The paper's output: an RGBA8 volume (straight alpha per voxel), interpolated trilinearly
    /// with opacity-weighted colours.
    Preclassified,
    /// Classify after interpolation: the label volume picks the class of each sample, the
    /// class's [`crate::transfer::ClassStyle`] gives colour and opacity from the interpolated
    /// scalar's gradient.
    Postclassified,
}

/// How post-classification picks a sample's class from the eight surrounding labels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LabelInterpolation {
    /// The class whose trilinearly weighted indicator is largest: boundaries follow the 0.5
    /// level set of each class's indicator (smooth, no colour bleeding). The default.
    LargestIndicatorWeight,
    /// The label of the nearest voxel (blocky staircase boundaries; kept for comparison).
    Nearest,
}

/// The part of the volume drawn, in normalised volume coordinates ([0, 1] along each axis).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipBox {
    /// The low corner, (x, y, z) in [0, 1].
    pub min: [f32; 3],
    /// The high corner, (x, y, z) in [0, 1].
    pub max: [f32; 3],
}

impl ClipBox {
    /// The whole volume, nothing clipped.
    pub const WHOLE: ClipBox = ClipBox { min: [0.0; 3], max: [1.0; 3] };
}

/// A plane that cuts the volume open: samples at world points `p` (millimetres, the volume's
/// box centred on the origin, as the shader's world space) with `dot(normal, p) > offset_mm`
/// are not drawn. `normal` need not be unit length; it is normalised where used.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ClipPlane {
    /// Points from the part kept toward the part cut away (x, y, z of the volume's axes).
    pub normal: [f32; 3],
    /// The plane's signed distance from the volume's centre along `normal`, in mm.
    pub offset_mm: f32,
}

impl ClipPlane {
    /// A finite plane with a direction.
    pub fn is_usable(&self) -> bool {
        let length = self.normal.iter().map(|n| n * n).sum::<f32>().sqrt();
        self.normal.iter().all(|n| n.is_finite()) && length > 1e-6 && length.is_finite() && self.offset_mm.is_finite()
    }

    /// The plane with a unit normal; `None` when it is not [`Self::is_usable`].
    pub fn normalised(&self) -> Option<ClipPlane> {
        let length = self.normal.iter().map(|n| n * n).sum::<f32>().sqrt();
        self.is_usable().then(|| ClipPlane { normal: self.normal.map(|n| n / length), offset_mm: self.offset_mm })
    }

    /// True when the world point `point_mm` is cut away.
    pub fn cuts(&self, point_mm: [f32; 3]) -> bool {
        let Some(unit) = self.normalised() else { return false };
        (0..3).map(|a| unit.normal[a] * point_mm[a]).sum::<f32>() > unit.offset_mm
    }
}

/// Blinn-Phong with a headlight, applied to the gradient's direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    /// Share of the colour lit regardless of direction.
    pub ambient: f32,
    /// Lambert term's weight.
    pub diffuse: f32,
    /// Highlight's weight (white, added to the colour).
    pub specular: f32,
    /// Blinn-Phong exponent: larger is a smaller, sharper highlight.
    pub shininess: f32,
}

impl Default for Lighting {
    fn default() -> Lighting {
        Lighting { ambient: 0.35, diffuse: 0.65, specular: 0.25, shininess: 24.0 }
    }
}

/// Everything about a frame except the camera and the data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Pre- or post-classified colours.
    pub mode: RenderMode,
    /// How post-classification picks a sample's class.
    pub label_interpolation: LabelInterpolation,
    /// Gradient-based shading; off draws the classified colours unlit.
    pub shading: bool,
    /// The shading's weights, used when `shading` is on.
    pub lighting: Lighting,
    /// Skip bricks that hold nothing visible (never changes the image, only the time).
    pub empty_space_skipping: bool,
    /// Offsets each ray's first sample by a per-pixel hash of up to one step (no wood grain).
    pub jitter: bool,
    /// Changes the jitter pattern (a UI may vary it per frame and accumulate).
    pub jitter_seed: u32,
    /// Distance between samples along a ray, in units of the smallest voxel spacing.
    pub step_voxels: f32,
    /// Rays stop once their accumulated opacity reaches this (early ray termination).
    pub opaque_alpha: f32,
    /// The part of the volume drawn.
    pub clip_box: ClipBox,
    /// A plane cutting the volume open; `None`: nothing cut beyond the box.
    pub clip_plane: Option<ClipPlane>,
    /// Straight RGBA in [0, 1], composited behind the volume.
    pub background: [f32; 4],
}

impl Default for RenderSettings {
    fn default() -> RenderSettings {
        RenderSettings {
            mode: RenderMode::Postclassified,
            label_interpolation: LabelInterpolation::LargestIndicatorWeight,
            shading: true,
            lighting: Lighting::default(),
            empty_space_skipping: true,
            jitter: true,
            jitter_seed: 0,
            step_voxels: 0.5,
            opaque_alpha: 0.99,
            clip_box: ClipBox::WHOLE,
            clip_plane: None,
            background: [0.0, 0.0, 0.0, 1.0],
        }
    }
}

impl RenderSettings {
    /// Refuses settings that would make the shader loop forever or draw garbage.
    pub fn validate(&self) -> Result<(), RenderError> {
        let bad = |name, value: String, expected| Err(RenderError::BadSetting { name, value, expected });
        if !(self.step_voxels.is_finite() && (0.01..=8.0).contains(&self.step_voxels)) {
            return bad("step_voxels", self.step_voxels.to_string(), "0.01 to 8");
        }
        if !(self.opaque_alpha > 0.0 && self.opaque_alpha <= 1.0) {
            return bad("opaque_alpha", self.opaque_alpha.to_string(), "above 0, at most 1");
        }
        let clip = self.clip_box;
        let in_unit = |v: f32| (0.0..=1.0).contains(&v);
        if !(clip.min.into_iter().chain(clip.max).all(in_unit) && (0..3).all(|a| clip.min[a] < clip.max[a])) {
            return bad("clip_box", format!("{:?} to {:?}", clip.min, clip.max), "0 <= min < max <= 1 on each axis");
        }
        if let Some(plane) = self.clip_plane
            && !plane.is_usable()
        {
            return bad("clip_plane", format!("{plane:?}"), "a finite normal of non-zero length and a finite offset");
        }
        if !self.background.into_iter().all(in_unit) {
            return bad("background", format!("{:?}", self.background), "each channel in [0, 1]");
        }
        let light = self.lighting;
        let terms_valid = [light.ambient, light.diffuse, light.specular].into_iter().all(|v| v.is_finite() && v >= 0.0);
        if !(terms_valid && light.shininess.is_finite() && light.shininess >= 1.0) {
            return bad("lighting", format!("{light:?}"), "non-negative terms and shininess >= 1");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_pass_and_each_bad_value_is_named() {
        assert!(RenderSettings::default().validate().is_ok());
        let cases = [
            ("step_voxels", RenderSettings { step_voxels: 0.0, ..Default::default() }),
            ("step_voxels", RenderSettings { step_voxels: f32::NAN, ..Default::default() }),
            ("opaque_alpha", RenderSettings { opaque_alpha: 0.0, ..Default::default() }),
            (
                "clip_box",
                RenderSettings { clip_box: ClipBox { min: [0.5; 3], max: [0.5, 1.0, 1.0] }, ..Default::default() },
            ),
            ("clip_box", RenderSettings { clip_box: ClipBox { min: [-0.1; 3], max: [1.0; 3] }, ..Default::default() }),
            ("background", RenderSettings { background: [2.0, 0.0, 0.0, 1.0], ..Default::default() }),
            (
                "clip_plane",
                RenderSettings {
                    clip_plane: Some(ClipPlane { normal: [0.0; 3], offset_mm: 0.0 }),
                    ..Default::default()
                },
            ),
            (
                "clip_plane",
                RenderSettings {
                    clip_plane: Some(ClipPlane { normal: [1.0, 0.0, 0.0], offset_mm: f32::NAN }),
                    ..Default::default()
                },
            ),
        ];
        for (name, settings) in cases {
            match settings.validate() {
                Err(RenderError::BadSetting { name: found, .. }) => assert_eq!(found, name),
                other => panic!("{name}: {other:?}"),
            }
        }
    }
}
