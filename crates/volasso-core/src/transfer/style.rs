//! One class's appearance (paper §3.5): the hue range of eq. 4, saturation (eq. 7), value
//! (eq. 8), and the opacity of eq. 9 after its rescaling into [0.2, 1], as a line in the
//! gradient factor `F_v = G_v / gradient_max` (eq. 5).
//!
//! Eq. 9 is `O_v = a_i (1 + F_v)` with `a_i = 1 - sigma_i^2 / max_j sigma_j^2`, rescaled
//! linearly over all voxels; a linear rescaling of a line is a line, so two numbers per class
//! (`opacity[0]` at `F_v = 0`, `opacity[1]` at `F_v = 1`) carry it exactly. That is what lets the
//! renderer classify after interpolation and lets emphasis and visibility change without
//! running the classifier again.

/// The appearance of one class.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ClassStyle {
    /// Hue in degrees at `F_v = 0` and at `F_v = 1` (eq. 4, 5); may wrap past 360.
    pub hue_degrees: [f32; 2],
    /// Eq. 7, in [0, 1].
    pub saturation: f32,
    /// Eq. 8, in [0, 1].
    pub value: f32,
    /// Opacity at `F_v = 0` and `F_v = 1` (eq. 9 after rescaling), before emphasis.
    pub opacity: [f32; 2],
    /// The largest gradient magnitude of the class's voxels (eq. 5's denominator), in the
    /// volume's value units per mm.
    pub gradient_max: f32,
    /// User emphasis: multiplies the opacity (1 = as computed; 0 hides the class).
    pub emphasis: f32,
    /// False hides the class: its voxels render fully transparent.
    pub visible: bool,
}

impl ClassStyle {
    /// The gradient factor `F_v` of eq. 5 for a gradient magnitude, clamped to [0, 1].
    pub fn gradient_factor(&self, gradient: f32) -> f32 {
        if self.gradient_max > 0.0 { (gradient / self.gradient_max).clamp(0.0, 1.0) } else { 0.0 }
    }

    /// Straight (not premultiplied) RGBA in [0, 1] for a voxel of this class with gradient
    /// magnitude `gradient`; fully transparent when the class is hidden.
    pub fn rgba(&self, gradient: f32) -> [f32; 4] {
        if !self.visible {
            return [0.0; 4];
        }
        let factor = self.gradient_factor(gradient);
        let hue = self.hue_degrees[0] + (self.hue_degrees[1] - self.hue_degrees[0]) * factor;
        let [r, g, b] = hsv_to_rgb(hue, self.saturation, self.value);
        let opacity = (self.opacity[0] + (self.opacity[1] - self.opacity[0]) * factor) * self.emphasis;
        [r, g, b, opacity.clamp(0.0, 1.0)]
    }
}

/// HSV (hue in degrees, any real; saturation and value in [0, 1]) to RGB in [0, 1].
pub fn hsv_to_rgb(hue_degrees: f32, saturation: f32, value: f32) -> [f32; 3] {
    let hue = hue_degrees.rem_euclid(360.0) / 60.0;
    let chroma = value * saturation;
    let x = chroma * (1.0 - ((hue % 2.0) - 1.0).abs());
    let (r, g, b) = match hue as u32 {
        0 => (chroma, x, 0.0),
        1 => (x, chroma, 0.0),
        2 => (0.0, chroma, x),
        3 => (0.0, x, chroma),
        4 => (x, 0.0, chroma),
        _ => (chroma, 0.0, x),
    };
    let m = value - chroma;
    [r + m, g + m, b + m]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn style() -> ClassStyle {
        ClassStyle {
            hue_degrees: [100.0, 118.0],
            saturation: 0.9,
            value: 0.8,
            opacity: [0.2, 0.6],
            gradient_max: 50.0,
            emphasis: 1.0,
            visible: true,
        }
    }

    #[test]
    fn hsv_primaries_and_wrapping() {
        let close = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
        assert!(close(hsv_to_rgb(0.0, 1.0, 1.0), [1.0, 0.0, 0.0]));
        assert!(close(hsv_to_rgb(120.0, 1.0, 1.0), [0.0, 1.0, 0.0]));
        assert!(close(hsv_to_rgb(240.0, 1.0, 1.0), [0.0, 0.0, 1.0]));
        assert!(close(hsv_to_rgb(360.0 + 240.0, 1.0, 1.0), [0.0, 0.0, 1.0]));
        assert!(close(hsv_to_rgb(-120.0, 1.0, 1.0), [0.0, 0.0, 1.0]));
        assert!(close(hsv_to_rgb(77.0, 0.0, 0.5), [0.5, 0.5, 0.5]));
    }

    #[test]
    fn opacity_and_hue_follow_the_gradient_factor() {
        let s = style();
        assert_eq!(s.rgba(0.0)[3], 0.2);
        assert!((s.rgba(25.0)[3] - 0.4).abs() < 1e-6);
        assert_eq!(s.rgba(500.0)[3], 0.6, "F_v is clamped to 1");
        let hidden = ClassStyle { visible: false, ..s.clone() };
        assert_eq!(hidden.rgba(10.0), [0.0; 4]);
        let faint = ClassStyle { emphasis: 0.5, ..s };
        assert_eq!(faint.rgba(0.0)[3], 0.1);
    }
}
