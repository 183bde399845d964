//! The orbit camera: azimuth and elevation around the volume's centre, zoom, pan, and an
//! orthographic or perspective projection; and the per-frame [`ViewRays`] the shader builds
//! its rays from.
//!
//! World space is millimetres with the volume's box (`dims * spacing_mm`) centred on the
//! origin; +z is the volume's slice axis and is "up" at elevation 0. At azimuth 0 and
//! elevation 0 the camera sits on the -y side looking along +y, with +x to the right of the
//! image. Azimuth turns the camera counter-clockwise about +z seen from above; elevation lifts
//! it towards +z. At zoom 1 the box's bounding sphere just fits the image.
//!
//! Never: touches the GPU; the shader's twin of the ray construction is `fragment_main` in
//! `shaders/raycast.wgsl`.

/// How rays leave the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Parallel rays: sizes on screen do not depend on depth (what the image tests measure).
    Orthographic,
    /// Rays from one eye point, with this vertical field of view.
    Perspective {
        /// The full vertical field of view, in degrees (clamped to 1-170).
        fov_y_degrees: f32,
    },
}

/// An orbit camera around the volume's centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Turn about +z, counter-clockwise seen from above; 0 looks along +y.
    pub azimuth_degrees: f32,
    /// Lift towards +z; 0 is level, 90 looks straight down.
    pub elevation_degrees: f32,
    /// 1 fits the bounding sphere of the volume's box; 2 shows it twice as large.
    pub zoom: f32,
    /// Offset of the orbit centre in the image plane, in mm along the image's right and up.
    pub pan_mm: [f32; 2],
    /// Orthographic or perspective.
    pub projection: Projection,
}

impl Default for Camera {
    fn default() -> Camera {
        Camera {
            azimuth_degrees: 30.0,
            elevation_degrees: 20.0,
            zoom: 1.0,
            pan_mm: [0.0, 0.0],
            projection: Projection::Perspective { fov_y_degrees: 30.0 },
        }
    }
}

/// Where the rays of one frame start and go, in world millimetres (see [`Camera::view_rays`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewRays {
    /// The eye point (perspective) or a point on the plane rays start from (orthographic), in mm.
    pub eye_in_world: [f32; 3],
    /// Unit vector along the image's +x.
    pub right_in_world: [f32; 3],
    /// Unit vector along the image's up.
    pub up_in_world: [f32; 3],
    /// Unit vector the camera looks along.
    pub forward_in_world: [f32; 3],
    /// Orthographic: half the image height in mm. Perspective: tan(fov_y / 2).
    pub view_half_height: f32,
    /// True for a perspective projection, false for orthographic.
    pub perspective: bool,
    /// Image width over height.
    pub aspect: f32,
}

impl Camera {
    /// The camera of a straight-on view along +y, orthographic (tests and thumbnails).
    pub fn orthographic_front() -> Camera {
        Camera {
            azimuth_degrees: 0.0,
            elevation_degrees: 0.0,
            projection: Projection::Orthographic,
            ..Camera::default()
        }
    }

    /// The rays for a box of `extent_mm` seen in an image of `width_pixels x height_pixels`.
    pub fn view_rays(&self, extent_mm: [f32; 3], width_pixels: u32, height_pixels: u32) -> ViewRays {
        let aspect = width_pixels.max(1) as f32 / height_pixels.max(1) as f32;
        let radius_mm = 0.5 * length(extent_mm);
        // A portrait image must fit the sphere across its narrower width.
        let fit = if aspect < 1.0 { 1.0 / aspect } else { 1.0 };
        let zoom = if self.zoom > 0.0 { self.zoom } else { 1.0 };
        let azimuth = self.azimuth_degrees.to_radians();
        let elevation = self.elevation_degrees.to_radians();
        let towards_eye = [elevation.cos() * azimuth.sin(), -elevation.cos() * azimuth.cos(), elevation.sin()];
        let forward = scale(towards_eye, -1.0);
        // Independent of elevation, so the poles are not singular.
        let right = [azimuth.cos(), azimuth.sin(), 0.0];
        let up = cross(right, forward);
        let target = add(scale(right, -self.pan_mm[0]), scale(up, -self.pan_mm[1]));
        match self.projection {
            Projection::Orthographic => ViewRays {
                eye_in_world: add(target, scale(towards_eye, 2.0 * radius_mm + 1.0)),
                right_in_world: right,
                up_in_world: up,
                forward_in_world: forward,
                view_half_height: radius_mm * fit / zoom,
                perspective: false,
                aspect,
            },
            Projection::Perspective { fov_y_degrees } => {
                let half_fov = 0.5 * fov_y_degrees.clamp(1.0, 170.0).to_radians();
                let distance_mm = radius_mm * fit / (half_fov.sin() * zoom);
                ViewRays {
                    eye_in_world: add(target, scale(towards_eye, distance_mm)),
                    right_in_world: right,
                    up_in_world: up,
                    forward_in_world: forward,
                    view_half_height: half_fov.tan(),
                    perspective: true,
                    aspect,
                }
            }
        }
    }

    /// Millimetres per pixel in the plane through the orbit centre (for turning a finger's drag
    /// into `pan_mm`).
    pub fn mm_per_pixel(&self, extent_mm: [f32; 3], width_pixels: u32, height_pixels: u32) -> f32 {
        let rays = self.view_rays(extent_mm, width_pixels, height_pixels);
        let half_height_mm = if rays.perspective {
            let target = add(scale(rays.right_in_world, -self.pan_mm[0]), scale(rays.up_in_world, -self.pan_mm[1]));
            length(sub(rays.eye_in_world, target)) * rays.view_half_height
        } else {
            rays.view_half_height
        };
        2.0 * half_height_mm / height_pixels.max(1) as f32
    }

    /// Moves the image content by a drag of `(dx, dy)` pixels (x right, y down).
    pub fn pan_by_pixels(&mut self, dx: f32, dy: f32, extent_mm: [f32; 3], width_pixels: u32, height_pixels: u32) {
        let mm = self.mm_per_pixel(extent_mm, width_pixels, height_pixels);
        self.pan_mm[0] += dx * mm;
        self.pan_mm[1] -= dy * mm;
    }
}

impl ViewRays {
    /// The pixel (x right, y down, pixel centres at +0.5) where `point_in_world` appears, or
    /// `None` behind a perspective eye. The twin of the ray construction in the shader.
    pub fn project_to_pixel(
        &self,
        point_in_world: [f32; 3],
        width_pixels: u32,
        height_pixels: u32,
    ) -> Option<[f32; 2]> {
        let offset = sub(point_in_world, self.eye_in_world);
        let (x, y, depth) =
            (dot(offset, self.right_in_world), dot(offset, self.up_in_world), dot(offset, self.forward_in_world));
        let (ndc_x, ndc_y) = if self.perspective {
            if depth <= 0.0 {
                return None;
            }
            (x / (depth * self.view_half_height * self.aspect), y / (depth * self.view_half_height))
        } else {
            (x / (self.view_half_height * self.aspect), y / self.view_half_height)
        };
        Some([(ndc_x + 1.0) * 0.5 * width_pixels as f32, (1.0 - ndc_y) * 0.5 * height_pixels as f32])
    }
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn length(a: [f32; 3]) -> f32 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f32; 3], b: [f32; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5)
    }

    #[test]
    fn the_view_basis_is_orthonormal_and_right_handed_everywhere() {
        for azimuth in [-170.0, 0.0, 37.0, 90.0, 200.0] {
            for elevation in [-90.0, -45.0, 0.0, 30.0, 90.0] {
                let camera = Camera { azimuth_degrees: azimuth, elevation_degrees: elevation, ..Camera::default() };
                let rays = camera.view_rays([10.0, 20.0, 30.0], 100, 80);
                let (r, u, f) = (rays.right_in_world, rays.up_in_world, rays.forward_in_world);
                for v in [r, u, f] {
                    assert!((length(v) - 1.0).abs() < 1e-5);
                }
                assert!(dot(r, u).abs() < 1e-5 && dot(r, f).abs() < 1e-5 && dot(u, f).abs() < 1e-5);
                assert!(close(cross(r, u), scale(f, -1.0)), "image x, y and the view towards the eye");
            }
        }
    }

    #[test]
    fn front_view_looks_along_y_with_z_up() {
        let rays = Camera::orthographic_front().view_rays([64.0, 64.0, 64.0], 128, 128);
        assert!(close(rays.forward_in_world, [0.0, 1.0, 0.0]));
        assert!(close(rays.right_in_world, [1.0, 0.0, 0.0]));
        assert!(close(rays.up_in_world, [0.0, 0.0, 1.0]));
        let centre = rays.project_to_pixel([0.0, 0.0, 0.0], 128, 128).unwrap();
        assert!((centre[0] - 64.0).abs() < 1e-4 && (centre[1] - 64.0).abs() < 1e-4);
        let top = rays.project_to_pixel([0.0, 0.0, 10.0], 128, 128).unwrap();
        assert!(top[1] < 64.0, "+z is up in the image, and image y grows downwards");
    }

    #[test]
    fn zoom_scales_the_image_and_pan_follows_the_finger() {
        let extent = [64.0, 64.0, 64.0];
        for projection in [Projection::Orthographic, Projection::Perspective { fov_y_degrees: 40.0 }] {
            let mut camera = Camera { projection, ..Camera::default() };
            let near = camera.mm_per_pixel(extent, 200, 100);
            camera.zoom = 2.0;
            assert!((camera.mm_per_pixel(extent, 200, 100) * 2.0 - near).abs() < 1e-4 * near);
            let rays = camera.view_rays(extent, 200, 100);
            let before = rays.project_to_pixel([0.0; 3], 200, 100).unwrap();
            camera.pan_by_pixels(10.0, -5.0, extent, 200, 100);
            let after = camera.view_rays(extent, 200, 100).project_to_pixel([0.0; 3], 200, 100).unwrap();
            assert!((after[0] - before[0] - 10.0).abs() < 1e-3, "{before:?} -> {after:?}");
            assert!((after[1] - before[1] + 5.0).abs() < 1e-3, "{before:?} -> {after:?}");
        }
    }

    #[test]
    fn at_zoom_one_the_bounding_sphere_fits_portrait_and_landscape_images() {
        let extent = [30.0, 40.0, 120.0];
        let radius = 0.5 * length(extent);
        for (width, height) in [(300, 100), (100, 300)] {
            let camera = Camera { projection: Projection::Orthographic, ..Camera::default() };
            let rays = camera.view_rays(extent, width, height);
            let half_width = rays.view_half_height * rays.aspect;
            assert!(rays.view_half_height >= radius - 1e-3 && half_width >= radius - 1e-3);
            assert!(rays.view_half_height.min(half_width) <= radius + 1e-3);
        }
    }
}
