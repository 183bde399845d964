//! The crate's one deterministic random number generator: SplitMix64 (Steele, Lea & Flood,
//! "Fast splittable pseudorandom number generators", 2014).
//!
//! Every random choice in volasso (phantom noise, stratified capping of training voxels, test
//! data) is seeded, so a run is reproducible bit for bit. [`SplitMix64`] is a sequential stream;
//! [`hash64`] is the same mixing function used statelessly, so that a parallel pass can draw
//! the noise of voxel `i` from `(seed, i)` alone and get identical bytes whatever the thread
//! schedule.
//!
//! Never: used for anything cryptographic.

/// Golden-ratio increment of SplitMix64.
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// The SplitMix64 finaliser: a bijective avalanche mix of 64 bits.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A well-mixed 64-bit value for `(seed, key)`: the `key`-th output of the SplitMix64 stream
/// seeded with `seed`, computed without walking the stream.
#[inline]
pub fn hash64(seed: u64, key: u64) -> u64 {
    mix64(seed.wrapping_add(key.wrapping_add(1).wrapping_mul(GAMMA)))
}

/// Maps 64 random bits to a uniform `f64` in `[0, 1)` (the top 53 bits).
#[inline]
pub fn unit_f64(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// An approximately standard normal value from 64 random bits: the sum of four uniform 16-bit
/// parts, centred and scaled to unit variance (Irwin-Hall, |value| <= 3.46). Cheap enough for a
/// value per voxel and close enough to Gaussian for CT-like noise.
#[inline]
pub fn gaussian_from_bits(bits: u64) -> f32 {
    let sum = (bits & 0xFFFF) + ((bits >> 16) & 0xFFFF) + ((bits >> 32) & 0xFFFF) + (bits >> 48);
    // Each part is uniform on 0..=65535: mean 32767.5, variance (65536^2 - 1) / 12.
    const MEAN: f64 = 4.0 * 32767.5;
    const STD: f64 = 37837.23; // sqrt(4 * (65536^2 - 1) / 12)
    ((sum as f64 - MEAN) / STD) as f32
}

/// A sequential SplitMix64 stream.
#[derive(Clone, Debug)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// A stream starting from `seed`; the same seed gives the same numbers.
    pub fn new(seed: u64) -> SplitMix64 {
        SplitMix64 { state: seed }
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GAMMA);
        mix64(self.state)
    }

    /// A uniform `f64` in `[0, 1)`.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        unit_f64(self.next_u64())
    }

    /// A uniform integer in `0..bound` (Lemire's multiply-shift, with rejection so that it is
    /// exactly uniform). `bound` must be non-zero.
    pub fn below(&mut self, bound: u64) -> u64 {
        debug_assert!(bound > 0);
        let threshold = bound.wrapping_neg() % bound;
        loop {
            let product = (self.next_u64() as u128) * (bound as u128);
            if (product as u64) >= threshold {
                return (product >> 64) as u64;
            }
        }
    }

    /// An approximately standard normal `f32` (see [`gaussian_from_bits`]).
    pub fn next_gaussian(&mut self) -> f32 {
        gaussian_from_bits(self.next_u64())
    }

    /// Shuffles the first `count` positions of `items` into a uniform random sample without
    /// replacement (a partial Fisher-Yates shuffle); the rest is left in some order.
    pub fn partial_shuffle<T>(&mut self, items: &mut [T], count: usize) {
        let count = count.min(items.len());
        for i in 0..count {
            let j = i + self.below((items.len() - i) as u64) as usize;
            items.swap(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_reference_splitmix64_stream() {
        // Reference values of SplitMix64 seeded with 1234567 (from the C reference code by
        // Sebastiano Vigna, used to seed xoshiro).
        let mut rng = SplitMix64::new(1234567);
        let expected = [
            6457827717110365317u64,
            3203168211198807973,
            9817491932198370423,
            4593380528125082431,
            16408922859458223821,
        ];
        for e in expected {
            assert_eq!(rng.next_u64(), e);
        }
    }

    #[test]
    fn hash64_is_the_stream_without_walking_it() {
        let mut rng = SplitMix64::new(99);
        for key in 0..10 {
            assert_eq!(hash64(99, key), rng.next_u64());
        }
    }

    #[test]
    fn below_is_in_range_and_covers_it() {
        let mut rng = SplitMix64::new(7);
        let mut seen = [0u32; 10];
        for _ in 0..10_000 {
            seen[rng.below(10) as usize] += 1;
        }
        assert!(seen.iter().all(|&n| (800..1200).contains(&n)), "{seen:?}");
    }

    #[test]
    fn gaussian_has_unit_variance_and_zero_mean() {
        let mut rng = SplitMix64::new(3);
        let n = 100_000;
        let values: Vec<f64> = (0..n).map(|_| rng.next_gaussian() as f64).collect();
        let mean = values.iter().sum::<f64>() / n as f64;
        let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.02, "mean {mean}");
        assert!((variance - 1.0).abs() < 0.02, "variance {variance}");
    }

    #[test]
    fn partial_shuffle_samples_without_replacement() {
        let mut rng = SplitMix64::new(11);
        let mut items: Vec<u32> = (0..50).collect();
        rng.partial_shuffle(&mut items, 20);
        let mut sample = items[..20].to_vec();
        sample.sort_unstable();
        sample.dedup();
        assert_eq!(sample.len(), 20);
        let mut all = items.clone();
        all.sort_unstable();
        assert_eq!(all, (0..50).collect::<Vec<u32>>());
    }
}
