// Volume ray caster: one full-screen triangle, one ray per fragment.
//
// Rust twin: src/render/raycast.rs (`RayCaster`, which binds everything below);
// `RenderUniforms` and `ClassEntry` mirror src/render/uniforms.rs byte for byte, `class_colour`
// mirrors `transfer::ClassStyle::rgba`, `hsv_to_rgb` mirrors `transfer::hsv_to_rgb`, and the
// ray construction mirrors `camera::ViewRays::project_to_pixel`.
//
// World space is millimetres, the volume's box (dims * spacing) centred on the origin; texture
// coordinates are world / extent + 0.5, so voxel i has its centre at (i + 0.5) / dims.

const MODE_PRECLASSIFIED: u32 = 0u;
const MODE_POSTCLASSIFIED: u32 = 1u;
const FLAG_SHADING: u32 = 1u;
const FLAG_EMPTY_SPACE_SKIPPING: u32 = 2u;
const FLAG_JITTER: u32 = 4u;
const FLAG_SRGB_OUTPUT: u32 = 8u;
const FLAG_NEAREST_LABEL: u32 = 16u;
const CLASS_TABLE_SIZE: u32 = 256u;
const BRICK_SIZE_VOXELS: u32 = 8u;
// Twin of `render::cells::MIXED_CELL`: a cell whose eight labels differ.
const MIXED_CELL: u32 = 255u;

struct RenderUniforms {
    eye_in_world: vec3<f32>,
    view_half_height: f32,
    right_in_world: vec3<f32>,
    aspect: f32,
    up_in_world: vec3<f32>,
    projection: u32,
    forward_in_world: vec3<f32>,
    step_mm: f32,
    extent_mm: vec3<f32>,
    reference_step_mm: f32,
    dims: vec3<f32>,
    value_min: f32,
    clip_min: vec3<f32>,
    value_span: f32,
    clip_max: vec3<f32>,
    opaque_alpha: f32,
    background: vec4<f32>,
    lighting: vec4<f32>,
    viewport_size: vec2<f32>,
    mode: u32,
    flags: u32,
    brick_dims: vec3<u32>,
    jitter_seed: u32,
    max_steps: u32,
    // Unit normal and offset (mm): points with dot(normal, p) > offset are cut away.
    clip_plane: vec4<f32>,
}

struct ClassEntry {
    hue_degrees: vec2<f32>,
    opacity: vec2<f32>,
    saturation: f32,
    value: f32,
    gradient_max: f32,
    emphasis: f32,
}

// The frame's parameters and the class table are read-only storage, not uniform buffers:
// lavapipe (Mesa's CPU Vulkan driver, the 3-D view on a panel without a GPU) compiles a new
// shader variant with the values of a uniform buffer inlined whenever they change, i.e. every
// frame, and keeps each one: about 2 MB of resident memory a frame
// (docs/decisions/0017-render-storage-buffers.md).
@group(0) @binding(0) var<storage, read> frame: RenderUniforms;
@group(0) @binding(1) var<storage, read> class_table: array<ClassEntry, CLASS_TABLE_SIZE>;
@group(0) @binding(2) var scalar_volume: texture_3d<f32>;
@group(0) @binding(3) var label_volume: texture_3d<u32>;
@group(0) @binding(4) var rgba_volume: texture_3d<f32>;
@group(0) @binding(5) var rgba_bricks: texture_3d<u32>;
@group(0) @binding(6) var label_bricks: texture_3d<u32>;
@group(0) @binding(7) var volume_sampler: sampler;
@group(0) @binding(8) var cell_labels: texture_3d<u32>;

@vertex
fn vertex_main(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    // One triangle covering the viewport: (-1,-1), (3,-1), (-1,3).
    let corner = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 0.0, 1.0);
}

fn has_flag(flag: u32) -> bool {
    return (frame.flags & flag) != 0u;
}

// PCG hash (Jarzynski & Olano 2020): decorrelated per-pixel jitter, so no wood grain.
fn pcg_hash(input: u32) -> u32 {
    let state = input * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn pixel_jitter(pixel: vec2<u32>) -> f32 {
    let hash = pcg_hash(pixel.x ^ pcg_hash(pixel.y ^ pcg_hash(frame.jitter_seed)));
    return f32(hash >> 8u) / 16777216.0;
}

// Twin of `transfer::hsv_to_rgb`.
fn hsv_to_rgb(hue_degrees: f32, saturation: f32, value: f32) -> vec3<f32> {
    let wrapped = hue_degrees - 360.0 * floor(hue_degrees / 360.0);
    let hue = wrapped / 60.0;
    let chroma = value * saturation;
    let x = chroma * (1.0 - abs((hue - 2.0 * floor(hue / 2.0)) - 1.0));
    let sector = min(u32(hue), 5u);
    var rgb: vec3<f32>;
    switch sector {
        case 0u: { rgb = vec3<f32>(chroma, x, 0.0); }
        case 1u: { rgb = vec3<f32>(x, chroma, 0.0); }
        case 2u: { rgb = vec3<f32>(0.0, chroma, x); }
        case 3u: { rgb = vec3<f32>(0.0, x, chroma); }
        case 4u: { rgb = vec3<f32>(x, 0.0, chroma); }
        default: { rgb = vec3<f32>(chroma, 0.0, x); }
    }
    return rgb + vec3<f32>(value - chroma);
}

// Twin of `ClassStyle::rgba`: straight RGBA of a class at a gradient magnitude (value / mm).
fn class_colour(entry: ClassEntry, gradient_magnitude: f32) -> vec4<f32> {
    var factor = 0.0;
    if entry.gradient_max > 0.0 {
        factor = clamp(gradient_magnitude / entry.gradient_max, 0.0, 1.0);
    }
    let hue = entry.hue_degrees.x + (entry.hue_degrees.y - entry.hue_degrees.x) * factor;
    let opacity = (entry.opacity.x + (entry.opacity.y - entry.opacity.x) * factor) * entry.emphasis;
    return vec4<f32>(hsv_to_rgb(hue, entry.saturation, entry.value), clamp(opacity, 0.0, 1.0));
}

// Central differences one voxel apart, in physical value units per mm.
fn scalar_gradient(texture_position: vec3<f32>) -> vec3<f32> {
    let step = 1.0 / frame.dims;
    let spacing_mm = frame.extent_mm / frame.dims;
    let dx = vec3<f32>(step.x, 0.0, 0.0);
    let dy = vec3<f32>(0.0, step.y, 0.0);
    let dz = vec3<f32>(0.0, 0.0, step.z);
    let difference = vec3<f32>(
        textureSampleLevel(scalar_volume, volume_sampler, texture_position + dx, 0.0).r
            - textureSampleLevel(scalar_volume, volume_sampler, texture_position - dx, 0.0).r,
        textureSampleLevel(scalar_volume, volume_sampler, texture_position + dy, 0.0).r
            - textureSampleLevel(scalar_volume, volume_sampler, texture_position - dy, 0.0).r,
        textureSampleLevel(scalar_volume, volume_sampler, texture_position + dz, 0.0).r
            - textureSampleLevel(scalar_volume, volume_sampler, texture_position - dz, 0.0).r,
    );
    return difference * frame.value_span / (2.0 * spacing_mm);
}

// The same for the opacity of the pre-classified volume (per mm), for shading only.
fn opacity_gradient(texture_position: vec3<f32>) -> vec3<f32> {
    let step = 1.0 / frame.dims;
    let spacing_mm = frame.extent_mm / frame.dims;
    let dx = vec3<f32>(step.x, 0.0, 0.0);
    let dy = vec3<f32>(0.0, step.y, 0.0);
    let dz = vec3<f32>(0.0, 0.0, step.z);
    let difference = vec3<f32>(
        textureSampleLevel(rgba_volume, volume_sampler, texture_position + dx, 0.0).a
            - textureSampleLevel(rgba_volume, volume_sampler, texture_position - dx, 0.0).a,
        textureSampleLevel(rgba_volume, volume_sampler, texture_position + dy, 0.0).a
            - textureSampleLevel(rgba_volume, volume_sampler, texture_position - dy, 0.0).a,
        textureSampleLevel(rgba_volume, volume_sampler, texture_position + dz, 0.0).a
            - textureSampleLevel(rgba_volume, volume_sampler, texture_position - dz, 0.0).a,
    );
    return difference / (2.0 * spacing_mm);
}

// Blinn-Phong with a headlight (light and eye along the ray), two-sided: a gradient has no
// preferred side for a surface seen from inside a volume.
fn shade(colour: vec3<f32>, gradient: vec3<f32>, ray_direction: vec3<f32>, gradient_scale: f32) -> vec3<f32> {
    let magnitude = length(gradient);
    let ambient = frame.lighting.x;
    let diffuse = frame.lighting.y;
    if magnitude <= 1e-6 * gradient_scale {
        // Homogeneous material has no normal; light it as if it faced the viewer.
        return colour * (ambient + diffuse);
    }
    let facing = abs(dot(gradient / magnitude, ray_direction));
    let specular = frame.lighting.z * pow(max(facing, 1e-6), frame.lighting.w);
    return min(colour * (ambient + diffuse * facing) + vec3<f32>(specular), vec3<f32>(1.0));
}

// The class of a sample from the eight labels around it: the class whose trilinearly weighted
// indicator is largest (background competes too), or the nearest voxel's label.
fn sample_label(texture_position: vec3<f32>) -> u32 {
    let voxel_position = texture_position * frame.dims - 0.5;
    let base = floor(voxel_position);
    // Away from class borders the eight labels agree: one fetch of the cell's code answers
    // (see render::cells); the half-voxel layer at the near faces has no cell.
    if all(base >= vec3<f32>(0.0)) {
        let code = textureLoad(cell_labels, vec3<i32>(base), 0).r;
        if code != MIXED_CELL {
            return code;
        }
    }
    let fraction = voxel_position - base;
    let last_voxel = vec3<i32>(frame.dims) - 1;
    var labels: array<u32, 8>;
    var weights: array<f32, 8>;
    for (var corner = 0u; corner < 8u; corner++) {
        let offset = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        let voxel = clamp(vec3<i32>(base) + vec3<i32>(offset), vec3<i32>(0), last_voxel);
        labels[corner] = textureLoad(label_volume, voxel, 0).r;
        let along = select(1.0 - fraction, fraction, offset == vec3<u32>(1u));
        weights[corner] = along.x * along.y * along.z;
    }
    var uniform_neighbourhood = true;
    for (var corner = 1u; corner < 8u; corner++) {
        uniform_neighbourhood = uniform_neighbourhood && labels[corner] == labels[0];
    }
    if uniform_neighbourhood {
        return labels[0];
    }
    if has_flag(FLAG_NEAREST_LABEL) {
        let nearest = vec3<u32>(fraction >= vec3<f32>(0.5));
        return labels[nearest.x | (nearest.y << 1u) | (nearest.z << 2u)];
    }
    var label = 0u;
    var best_weight = -1.0;
    for (var i = 0u; i < 8u; i++) {
        var weight = 0.0;
        for (var j = 0u; j < 8u; j++) {
            weight += select(0.0, weights[j], labels[j] == labels[i]);
        }
        if weight > best_weight {
            best_weight = weight;
            label = labels[i];
        }
    }
    return label;
}

// Post-classification: the sample's class (`sample_label`), then that class's colour from the
// interpolated scalar's gradient. Straight RGBA.
fn postclassified_sample(texture_position: vec3<f32>, ray_direction: vec3<f32>) -> vec4<f32> {
    let label = sample_label(texture_position);
    if label == 0u {
        return vec4<f32>(0.0);
    }
    let entry = class_table[label];
    if entry.emphasis <= 0.0 {
        return vec4<f32>(0.0);
    }
    let gradient = scalar_gradient(texture_position);
    var colour = class_colour(entry, length(gradient));
    if colour.a > 0.0 && has_flag(FLAG_SHADING) {
        colour = vec4<f32>(shade(colour.rgb, gradient, ray_direction, frame.value_span), colour.a);
    }
    return colour;
}

// Pre-classification: the opacity-weighted RGBA volume, filtered trilinearly. Straight RGBA.
fn preclassified_sample(texture_position: vec3<f32>, ray_direction: vec3<f32>) -> vec4<f32> {
    let weighted = textureSampleLevel(rgba_volume, volume_sampler, texture_position, 0.0);
    if weighted.a <= 0.0 {
        return vec4<f32>(0.0);
    }
    var colour = min(weighted.rgb / weighted.a, vec3<f32>(1.0));
    if has_flag(FLAG_SHADING) {
        colour = shade(colour, opacity_gradient(texture_position), ray_direction, 1.0);
    }
    return vec4<f32>(colour, weighted.a);
}

fn brick_is_empty(brick: vec3<u32>) -> bool {
    if frame.mode == MODE_PRECLASSIFIED {
        return textureLoad(rgba_bricks, brick, 0).r == 0u;
    }
    return textureLoad(label_bricks, brick, 0).r == 0u;
}

fn srgb_to_linear(colour: vec3<f32>) -> vec3<f32> {
    let low = colour / 12.92;
    let high = pow((colour + 0.055) / 1.055, vec3<f32>(2.4));
    return select(high, low, colour <= vec3<f32>(0.04045));
}

@fragment
fn fragment_main(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    // 1. The ray through this pixel (twin of `ViewRays::project_to_pixel`).
    let ndc = vec2<f32>(
        position.x / frame.viewport_size.x * 2.0 - 1.0,
        1.0 - position.y / frame.viewport_size.y * 2.0,
    );
    let across = frame.right_in_world * (ndc.x * frame.view_half_height * frame.aspect)
        + frame.up_in_world * (ndc.y * frame.view_half_height);
    var origin = frame.eye_in_world;
    var direction = frame.forward_in_world;
    if frame.projection == 0u {
        origin += across;
    } else {
        direction = normalize(frame.forward_in_world + across);
    }

    // 2. Where it crosses the clipping box (slab test).
    let box_min = (frame.clip_min - 0.5) * frame.extent_mm;
    let box_max = (frame.clip_max - 0.5) * frame.extent_mm;
    let safe_direction = select(direction, vec3<f32>(1e-12), abs(direction) < vec3<f32>(1e-12));
    let inverse_direction = 1.0 / safe_direction;
    let t_to_min = (box_min - origin) * inverse_direction;
    let t_to_max = (box_max - origin) * inverse_direction;
    var t_entry = max(max(max(min(t_to_min.x, t_to_max.x), min(t_to_min.y, t_to_max.y)), min(t_to_min.z, t_to_max.z)), 0.0);
    var t_exit = min(min(max(t_to_min.x, t_to_max.x), max(t_to_min.y, t_to_max.y)), max(t_to_min.z, t_to_max.z));
    // The clip plane keeps the half-space dot(normal, p) <= offset: one more slab.
    let plane_facing = dot(frame.clip_plane.xyz, direction);
    let plane_room = frame.clip_plane.w - dot(frame.clip_plane.xyz, origin);
    if abs(plane_facing) < 1e-12 {
        if plane_room < 0.0 {
            t_exit = -1.0;
        }
    } else if plane_facing > 0.0 {
        t_exit = min(t_exit, plane_room / plane_facing);
    } else {
        t_entry = max(t_entry, plane_room / plane_facing);
    }

    // 3. March front to back from a jittered start, sample k at t_entry + (k + jitter) * step.
    var jitter = 0.5;
    if has_flag(FLAG_JITTER) {
        jitter = pixel_jitter(vec2<u32>(position.xy));
    }
    let step_mm = frame.step_mm;
    // Opacities are defined per reference_step_mm; a sample covers step_mm.
    let opacity_exponent = step_mm / frame.reference_step_mm;
    let brick_size = f32(BRICK_SIZE_VOXELS);
    var accumulated = vec4<f32>(0.0);
    var k = 0u;
    var iterations = 0u;
    // The brick of the previous sample and whether it is empty: most samples share it.
    var cached_brick = vec3<u32>(0xffffffffu);
    var cached_brick_empty = false;
    loop {
        let t = t_entry + (f32(k) + jitter) * step_mm;
        if t > t_exit || accumulated.a >= frame.opaque_alpha || iterations >= frame.max_steps {
            break;
        }
        iterations += 1u;
        let point_in_world = origin + direction * t;
        let texture_position = point_in_world / frame.extent_mm + 0.5;

        // 4. Empty-space skipping: jump to the first sample past an empty brick, on the same
        //    sample grid, so skipping never changes the image.
        if has_flag(FLAG_EMPTY_SPACE_SKIPPING) {
            let brick_position = clamp(texture_position * frame.dims / brick_size, vec3<f32>(0.0), vec3<f32>(frame.brick_dims - 1u));
            let brick = min(vec3<u32>(brick_position), frame.brick_dims - 1u);
            if any(brick != cached_brick) {
                cached_brick = brick;
                cached_brick_empty = brick_is_empty(brick);
            }
            if cached_brick_empty {
                let brick_low = (vec3<f32>(brick) * brick_size / frame.dims - 0.5) * frame.extent_mm;
                let brick_high = (min(vec3<f32>(brick + 1u) * brick_size, frame.dims) / frame.dims - 0.5) * frame.extent_mm;
                let t_low = (brick_low - origin) * inverse_direction;
                let t_high = (brick_high - origin) * inverse_direction;
                let t_leave = min(min(max(t_low.x, t_high.x), max(t_low.y, t_high.y)), max(t_low.z, t_high.z));
                let next = ceil((t_leave - t_entry) / step_mm - jitter);
                k = max(k + 1u, u32(clamp(next, 0.0, 4294967040.0)));
                continue;
            }
        }

        // 5. Classify, correct the opacity for the step, composite front to back.
        var sample: vec4<f32>;
        if frame.mode == MODE_PRECLASSIFIED {
            sample = preclassified_sample(texture_position, direction);
        } else {
            sample = postclassified_sample(texture_position, direction);
        }
        if sample.a > 0.0 {
            // alpha' = 1 - (1 - alpha)^(step / reference step); pow(0, y) is undefined in WGSL.
            let transparency = 1.0 - min(sample.a, 1.0);
            let alpha = select(1.0 - pow(transparency, opacity_exponent), 1.0, transparency <= 0.0);
            accumulated += (1.0 - accumulated.a) * vec4<f32>(sample.rgb * alpha, alpha);
        }
        k += 1u;
    }

    // 6. The background behind, and straight alpha out.
    let background = vec4<f32>(frame.background.rgb * frame.background.a, frame.background.a);
    let composite = accumulated + (1.0 - accumulated.a) * background;
    var colour = vec3<f32>(0.0);
    if composite.a > 0.0 {
        colour = min(composite.rgb / composite.a, vec3<f32>(1.0));
    }
    if has_flag(FLAG_SRGB_OUTPUT) {
        // The table's colours are display values; an sRGB target encodes what it receives.
        colour = srgb_to_linear(colour);
    }
    return vec4<f32>(colour, composite.a);
}
