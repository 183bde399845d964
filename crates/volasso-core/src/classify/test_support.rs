//! Seeded generated problems for the classify tests. A tiny SplitMix64 stands in for the
//! `rand` crate so that every test is reproducible bit for bit.

/// SplitMix64 (Steele, Lea & Flood 2014): one u64 of state, good enough for test data.
pub(crate) struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        let u = 1.0 - self.uniform();
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// A uniformly random permutation of 0..count (Fisher-Yates).
    pub fn permutation(&mut self, count: usize) -> Vec<usize> {
        let mut order: Vec<usize> = (0..count).collect();
        for i in (1..count).rev() {
            let j = (self.next_u64() % (i as u64 + 1)) as usize;
            order.swap(i, j);
        }
        order
    }
}

/// Gaussian blobs: class c (1-based) has `per_class` points around centre c * `separation`
/// along a class-specific direction, with unit spread. Returns (row-major points, labels).
pub(crate) fn blobs(
    rng: &mut SplitMix64,
    classes: usize,
    per_class: usize,
    dim: usize,
    separation: f64,
) -> (Vec<f64>, Vec<u8>) {
    let mut points = Vec::with_capacity(classes * per_class * dim);
    let mut labels = Vec::with_capacity(classes * per_class);
    for class in 0..classes {
        for _ in 0..per_class {
            for k in 0..dim {
                let centre = if k == class % dim { separation * (1 + class / dim) as f64 } else { 0.0 };
                points.push(centre + rng.normal());
            }
            labels.push(class as u8 + 1);
        }
    }
    (points, labels)
}
