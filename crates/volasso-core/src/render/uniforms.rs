//! The bytes the ray caster hands the shader each frame ([`RenderUniforms`]) and the per-class
//! table ([`ClassEntry`] x [`CLASS_TABLE_SIZE`]), laid out exactly as their WGSL twins of the
//! same names in `shaders/raycast.wgsl` (a test parses the shader and compares offsets).
//!
//! WGSL uniform layout: a `vec3<f32>` is 16-byte aligned and 12 bytes long, so each `[f32; 3]`
//! below is followed by one 4-byte scalar that fills its vec4 slot; the struct is padded to a
//! multiple of 16 bytes (`padding` fills the slot after `max_steps`).
//!
//! Never: computes colours (the table stores [`ClassStyle`]'s numbers unchanged; the shader's
//! `class_colour` is the twin of [`ClassStyle::rgba`]).

use super::camera::ViewRays;
use super::settings::{LabelInterpolation, RenderMode, RenderSettings};
use super::{RenderError, bricks};
use crate::transfer::ClassStyle;

/// Entries in the class table: one per 8-bit label, label 0 (background) included.
pub const CLASS_TABLE_SIZE: usize = 256;

/// `mode` value of [`RenderMode::Preclassified`].
pub const MODE_PRECLASSIFIED: u32 = 0;
/// `mode` value of [`RenderMode::Postclassified`].
pub const MODE_POSTCLASSIFIED: u32 = 1;
/// `flags` bit: gradient shading on.
pub const FLAG_SHADING: u32 = 1;
/// `flags` bit: skip empty bricks.
pub const FLAG_EMPTY_SPACE_SKIPPING: u32 = 2;
/// `flags` bit: jitter each ray's first sample.
pub const FLAG_JITTER: u32 = 4;
/// `flags` bit: the target is sRGB, so the shader hands it linear values.
pub const FLAG_SRGB_OUTPUT: u32 = 8;
/// `flags` bit: [`LabelInterpolation::Nearest`].
pub const FLAG_NEAREST_LABEL: u32 = 16;

/// Per-frame uniforms; WGSL twin `RenderUniforms`. Offsets in bytes on the right.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RenderUniforms {
    /// [`ViewRays::eye_in_world`], mm.
    pub eye_in_world: [f32; 3], // 0
    /// Orthographic: half the image height in mm; perspective: tan(fov_y / 2).
    pub view_half_height: f32, // 12
    /// [`ViewRays::right_in_world`].
    pub right_in_world: [f32; 3], // 16
    /// Image width over height.
    pub aspect: f32, // 28
    /// [`ViewRays::up_in_world`].
    pub up_in_world: [f32; 3], // 32
    /// 0 orthographic, 1 perspective.
    pub projection: u32, // 44
    /// [`ViewRays::forward_in_world`].
    pub forward_in_world: [f32; 3], // 48
    /// Distance between samples along a ray, in mm.
    pub step_mm: f32, // 60
    /// The volume's box (`dims * spacing_mm`), in mm.
    pub extent_mm: [f32; 3], // 64
    /// The distance at which a class's opacity is defined: the smallest voxel spacing.
    pub reference_step_mm: f32, // 76
    /// The volume's size in voxels, (x, y, z).
    pub dims: [f32; 3], // 80
    /// Physical value = `value_min + texel * value_span` (texel in [0, 1]).
    pub value_min: f32, // 92
    /// [`ClipBox::min`](super::ClipBox::min), normalised.
    pub clip_min: [f32; 3], // 96
    /// Physical value range a texel of 0 to 1 covers.
    pub value_span: f32, // 108
    /// [`ClipBox::max`](super::ClipBox::max), normalised.
    pub clip_max: [f32; 3], // 112
    /// Accumulated opacity at which a ray stops.
    pub opaque_alpha: f32, // 124
    /// Straight RGBA in [0, 1], composited behind the volume.
    pub background: [f32; 4], // 128
    /// Ambient, diffuse, specular, shininess.
    pub lighting: [f32; 4], // 144
    /// Width and height of the whole frame, in pixels.
    pub viewport_size: [f32; 2], // 160
    /// [`MODE_PRECLASSIFIED`] or [`MODE_POSTCLASSIFIED`].
    pub mode: u32, // 168
    /// `FLAG_*` bits.
    pub flags: u32, // 172
    /// Bricks along x, y and z.
    pub brick_dims: [u32; 3], // 176
    /// [`RenderSettings::jitter_seed`].
    pub jitter_seed: u32, // 188
    /// Bound on a ray's loop iterations (samples plus skipped bricks).
    pub max_steps: u32, // 192
    /// Zero; pads `max_steps` to the next 16-byte slot.
    pub padding: [u32; 3], // 196
    /// [`ClipPlane`](super::ClipPlane): unit normal (x, y, z) and offset in mm (w); a zero normal
    /// with a positive offset when there is none (then nothing is cut).
    pub clip_plane: [f32; 4], // 208, size 224
}

/// What the frame's volume looks like to the shader.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameVolume {
    /// Size in voxels, (x, y, z).
    pub dims: [usize; 3],
    /// Voxel spacing along x, y and z, in mm.
    pub spacing_mm: [f64; 3],
    /// Physical value of texel 0.
    pub value_min: f32,
    /// Physical value range texels 0 to 1 cover.
    pub value_span: f32,
}

impl RenderUniforms {
    /// The uniforms of a frame of `viewport_size` pixels (`srgb_output` for an sRGB target).
    pub fn new(
        rays: &ViewRays,
        settings: &RenderSettings,
        volume: &FrameVolume,
        viewport_size: [u32; 2],
        srgb_output: bool,
    ) -> RenderUniforms {
        let extent_mm: [f32; 3] = std::array::from_fn(|a| (volume.dims[a] as f64 * volume.spacing_mm[a]) as f32);
        let reference_step_mm = volume.spacing_mm.iter().copied().fold(f64::INFINITY, f64::min) as f32;
        let step_mm = reference_step_mm * settings.step_voxels;
        let brick_dims = bricks::brick_dims(volume.dims);
        let diagonal_mm = extent_mm.iter().map(|e| e * e).sum::<f32>().sqrt();
        // Every sample and every skipped brick is one iteration; this bound only guards
        // against a runaway loop, it never cuts a ray short.
        let max_steps = (diagonal_mm / step_mm).ceil() as u32 + brick_dims.iter().sum::<usize>() as u32 + 4;
        let flag = |on: bool, bit: u32| if on { bit } else { 0 };
        let flags = flag(settings.shading, FLAG_SHADING)
            | flag(settings.empty_space_skipping, FLAG_EMPTY_SPACE_SKIPPING)
            | flag(settings.jitter, FLAG_JITTER)
            | flag(srgb_output, FLAG_SRGB_OUTPUT)
            | flag(settings.label_interpolation == LabelInterpolation::Nearest, FLAG_NEAREST_LABEL);
        let light = settings.lighting;
        RenderUniforms {
            eye_in_world: rays.eye_in_world,
            view_half_height: rays.view_half_height,
            right_in_world: rays.right_in_world,
            aspect: rays.aspect,
            up_in_world: rays.up_in_world,
            projection: rays.perspective as u32,
            forward_in_world: rays.forward_in_world,
            step_mm,
            extent_mm,
            reference_step_mm,
            dims: volume.dims.map(|d| d as f32),
            value_min: volume.value_min,
            clip_min: settings.clip_box.min,
            value_span: volume.value_span,
            clip_max: settings.clip_box.max,
            opaque_alpha: settings.opaque_alpha,
            background: settings.background,
            lighting: [light.ambient, light.diffuse, light.specular, light.shininess],
            viewport_size: viewport_size.map(|v| v as f32),
            mode: match settings.mode {
                RenderMode::Preclassified => MODE_PRECLASSIFIED,
                RenderMode::Postclassified => MODE_POSTCLASSIFIED,
            },
            flags,
            brick_dims: brick_dims.map(|b| b as u32),
            jitter_seed: settings.jitter_seed,
            max_steps,
            padding: [0; 3],
            clip_plane: settings
                .clip_plane
                .and_then(|plane| plane.normalised())
                .map_or([0.0, 0.0, 0.0, 1.0], |plane| {
                    [plane.normal[0], plane.normal[1], plane.normal[2], plane.offset_mm]
                }),
        }
    }
}

/// One class's [`ClassStyle`], as the shader reads it; WGSL twin `ClassEntry`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ClassEntry {
    /// [`ClassStyle::hue_degrees`].
    pub hue_degrees: [f32; 2], // 0
    /// [`ClassStyle::opacity`].
    pub opacity: [f32; 2], // 8
    /// [`ClassStyle::saturation`].
    pub saturation: f32, // 16
    /// [`ClassStyle::value`].
    pub value: f32, // 20
    /// [`ClassStyle::gradient_max`].
    pub gradient_max: f32, // 24
    /// `ClassStyle::emphasis`, or 0 for a hidden class (its samples are then transparent,
    /// as `ClassStyle::rgba` makes them).
    pub emphasis: f32, // 28, size 32
}

impl From<&ClassStyle> for ClassEntry {
    fn from(style: &ClassStyle) -> ClassEntry {
        ClassEntry {
            hue_degrees: style.hue_degrees,
            opacity: style.opacity,
            saturation: style.saturation,
            value: style.value,
            gradient_max: style.gradient_max,
            emphasis: if style.visible { style.emphasis } else { 0.0 },
        }
    }
}

/// The table for label k = `styles[k - 1]`; label 0 and labels past the styles stay
/// transparent.
pub fn class_table(styles: &[ClassStyle]) -> Result<Vec<ClassEntry>, RenderError> {
    if styles.len() >= CLASS_TABLE_SIZE {
        return Err(RenderError::TooManyClasses { classes: styles.len(), max: CLASS_TABLE_SIZE - 1 });
    }
    let mut table = vec![ClassEntry::default(); CLASS_TABLE_SIZE];
    for (entry, style) in table[1..].iter_mut().zip(styles) {
        *entry = ClassEntry::from(style);
    }
    Ok(table)
}

/// Whether samples of each label can ever be visible (for empty-space skipping).
pub fn visible_labels(table: &[ClassEntry]) -> [bool; CLASS_TABLE_SIZE] {
    std::array::from_fn(|label| {
        table
            .get(label)
            .is_some_and(|entry| label > 0 && entry.emphasis > 0.0 && entry.opacity.iter().any(|o| *o > 0.0))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    /// Member offsets and size of the WGSL struct `name`, from the shader itself.
    fn wgsl_layout(name: &str) -> (Vec<(String, u32)>, u32) {
        let module = naga::front::wgsl::parse_str(super::super::raycast::SHADER_SOURCE).unwrap();
        let found = module.types.iter().find(|(_, ty)| ty.name.as_deref() == Some(name));
        match found.map(|(_, ty)| &ty.inner) {
            Some(naga::TypeInner::Struct { members, span }) => {
                (members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect(), *span)
            }
            other => panic!("{name} is not a struct in the shader: {other:?}"),
        }
    }

    fn wgsl_constant(name: &str) -> u32 {
        let module = naga::front::wgsl::parse_str(super::super::raycast::SHADER_SOURCE).unwrap();
        let (_, constant) = module.constants.iter().find(|(_, c)| c.name.as_deref() == Some(name)).unwrap();
        match module.global_expressions[constant.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => v,
            naga::Expression::Literal(naga::Literal::AbstractInt(v)) => v as u32,
            ref other => panic!("{name}: {other:?}"),
        }
    }

    #[test]
    fn render_uniforms_match_their_wgsl_twin() {
        let (members, span) = wgsl_layout("RenderUniforms");
        assert_eq!(span as usize, size_of::<RenderUniforms>());
        let rust = [
            ("eye_in_world", offset_of!(RenderUniforms, eye_in_world)),
            ("view_half_height", offset_of!(RenderUniforms, view_half_height)),
            ("right_in_world", offset_of!(RenderUniforms, right_in_world)),
            ("aspect", offset_of!(RenderUniforms, aspect)),
            ("up_in_world", offset_of!(RenderUniforms, up_in_world)),
            ("projection", offset_of!(RenderUniforms, projection)),
            ("forward_in_world", offset_of!(RenderUniforms, forward_in_world)),
            ("step_mm", offset_of!(RenderUniforms, step_mm)),
            ("extent_mm", offset_of!(RenderUniforms, extent_mm)),
            ("reference_step_mm", offset_of!(RenderUniforms, reference_step_mm)),
            ("dims", offset_of!(RenderUniforms, dims)),
            ("value_min", offset_of!(RenderUniforms, value_min)),
            ("clip_min", offset_of!(RenderUniforms, clip_min)),
            ("value_span", offset_of!(RenderUniforms, value_span)),
            ("clip_max", offset_of!(RenderUniforms, clip_max)),
            ("opaque_alpha", offset_of!(RenderUniforms, opaque_alpha)),
            ("background", offset_of!(RenderUniforms, background)),
            ("lighting", offset_of!(RenderUniforms, lighting)),
            ("viewport_size", offset_of!(RenderUniforms, viewport_size)),
            ("mode", offset_of!(RenderUniforms, mode)),
            ("flags", offset_of!(RenderUniforms, flags)),
            ("brick_dims", offset_of!(RenderUniforms, brick_dims)),
            ("jitter_seed", offset_of!(RenderUniforms, jitter_seed)),
            ("max_steps", offset_of!(RenderUniforms, max_steps)),
            ("clip_plane", offset_of!(RenderUniforms, clip_plane)),
        ];
        let rust: Vec<(String, u32)> = rust.iter().map(|(n, o)| (n.to_string(), *o as u32)).collect();
        assert_eq!(members, rust);
    }

    #[test]
    fn class_entries_match_their_wgsl_twin() {
        let (members, span) = wgsl_layout("ClassEntry");
        assert_eq!(span as usize, size_of::<ClassEntry>());
        let rust = [
            ("hue_degrees", offset_of!(ClassEntry, hue_degrees)),
            ("opacity", offset_of!(ClassEntry, opacity)),
            ("saturation", offset_of!(ClassEntry, saturation)),
            ("value", offset_of!(ClassEntry, value)),
            ("gradient_max", offset_of!(ClassEntry, gradient_max)),
            ("emphasis", offset_of!(ClassEntry, emphasis)),
        ];
        let rust: Vec<(String, u32)> = rust.iter().map(|(n, o)| (n.to_string(), *o as u32)).collect();
        assert_eq!(members, rust);
    }

    #[test]
    fn shader_constants_match_rust() {
        assert_eq!(wgsl_constant("MODE_PRECLASSIFIED"), MODE_PRECLASSIFIED);
        assert_eq!(wgsl_constant("MODE_POSTCLASSIFIED"), MODE_POSTCLASSIFIED);
        assert_eq!(wgsl_constant("FLAG_SHADING"), FLAG_SHADING);
        assert_eq!(wgsl_constant("FLAG_EMPTY_SPACE_SKIPPING"), FLAG_EMPTY_SPACE_SKIPPING);
        assert_eq!(wgsl_constant("FLAG_JITTER"), FLAG_JITTER);
        assert_eq!(wgsl_constant("FLAG_SRGB_OUTPUT"), FLAG_SRGB_OUTPUT);
        assert_eq!(wgsl_constant("FLAG_NEAREST_LABEL"), FLAG_NEAREST_LABEL);
        assert_eq!(wgsl_constant("CLASS_TABLE_SIZE") as usize, CLASS_TABLE_SIZE);
        assert_eq!(wgsl_constant("BRICK_SIZE_VOXELS") as usize, bricks::BRICK_SIZE_VOXELS);
        assert_eq!(wgsl_constant("MIXED_CELL"), super::super::cells::MIXED_CELL as u32);
    }

    #[test]
    fn the_table_puts_class_k_at_label_k_and_hides_what_is_hidden() {
        let style = ClassStyle {
            hue_degrees: [10.0, 20.0],
            saturation: 0.5,
            value: 0.9,
            opacity: [0.1, 0.4],
            gradient_max: 3.0,
            emphasis: 2.0,
            visible: true,
        };
        let hidden = ClassStyle { visible: false, ..style.clone() };
        let clear = ClassStyle { opacity: [0.0, 0.0], ..style.clone() };
        let table = class_table(&[style.clone(), hidden, clear]).unwrap();
        assert_eq!(table.len(), CLASS_TABLE_SIZE);
        assert_eq!(table[0], ClassEntry::default());
        assert_eq!(table[1].hue_degrees, [10.0, 20.0]);
        assert_eq!(table[1].emphasis, 2.0);
        assert_eq!(table[2].emphasis, 0.0);
        let visible = visible_labels(&table);
        assert_eq!(&visible[..5], &[false, true, false, false, false]);
        let too_many = vec![style; CLASS_TABLE_SIZE];
        assert!(matches!(class_table(&too_many), Err(RenderError::TooManyClasses { classes: 256, max: 255 })));
    }
}
