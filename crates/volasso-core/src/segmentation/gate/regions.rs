//! The gate's answer for every intensity, tabulated: the classes a band rule allows are
//! constant between consecutive band ends, so the rule is evaluated once per end and once per
//! stretch between two ends, and a voxel's lookup is a binary search over at most two ends a
//! class. The rule itself (`super::IntensityGate`) reads every band and costs tens of
//! instructions; labelling asks it for every evaluated voxel.
//!
//! Never: decides anything itself; it answers what the rule it was built from answers.

use super::ClassSet;

/// The class sets of every stretch of intensities between band ends, and of the ends.
#[derive(Clone, Debug, PartialEq)]
pub struct Regions {
    /// Every band end, sorted, without repeats.
    ends: Vec<f32>,
    /// `2 * ends.len() + 1` sets: below the first end, at it, between it and the next, ...,
    /// at the last end, above it.
    sets: Vec<ClassSet>,
}

impl Regions {
    /// The table of `rule` (constant between consecutive `ends`, finite).
    pub fn tabulate(ends: impl IntoIterator<Item = f32>, rule: impl Fn(f32) -> ClassSet) -> Regions {
        let mut ends: Vec<f32> = ends.into_iter().filter(|end| end.is_finite()).collect();
        ends.sort_by(f32::total_cmp);
        ends.dedup();
        // Midway between two floats, in f64: the difference of two large f32 overflows. A
        // stretch between two adjacent floats holds no intensity; its set is never read.
        let midway = |low: f32, high: f32| ((f64::from(low) + f64::from(high)) / 2.0) as f32;
        let mut sets = Vec::with_capacity(2 * ends.len() + 1);
        let mut below = f32::MIN;
        for &end in &ends {
            sets.push(rule(midway(below, end)));
            sets.push(rule(end));
            below = end;
        }
        sets.push(rule(midway(below, f32::MAX)));
        Regions { ends, sets }
    }

    /// The set of `intensity` (finite).
    pub fn set_of(&self, intensity: f32) -> ClassSet {
        let position = self.ends.partition_point(|&end| end < intensity);
        let at_end = self.ends.get(position) == Some(&intensity);
        self.sets[2 * position + usize::from(at_end)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_answers_what_its_rule_answers_at_the_ends_between_and_beyond() {
        // Bands [0, 10] (class 0) and [5, 20] (class 1), inclusive; beyond or between them, 4.
        let rule = |v: f32| {
            let mut set = 0;
            if (0.0..=10.0).contains(&v) {
                set |= 1;
            }
            if (5.0..=20.0).contains(&v) {
                set |= 2;
            }
            if set == 0 { 4 } else { set }
        };
        let table = Regions::tabulate([0.0, 10.0, 5.0, 20.0, 10.0], rule);
        for v in [-1e30, -3.0, 0.0, 2.5, 5.0, 7.0, 10.0, 10.5, 20.0, 21.0, 1e30, f32::MAX, f32::MIN] {
            assert_eq!(table.set_of(v), rule(v), "{v}");
        }
        let mut rng = crate::rng::SplitMix64::new(5);
        for _ in 0..1000 {
            let v = (rng.next_f64() * 40.0 - 10.0) as f32;
            assert_eq!(table.set_of(v), rule(v), "{v}");
        }
    }

    #[test]
    fn ends_near_the_largest_floats_keep_their_stretches_apart() {
        // A lying file's values reach the float range's ends: the stretches below the first
        // end and above the last still get the rule's sets there.
        for end in [1e38, -1e38] {
            let rule = |v: f32| {
                if v < end {
                    1
                } else if v > end {
                    4
                } else {
                    2
                }
            };
            let table = Regions::tabulate([end], rule);
            for v in [f32::MIN, -2e38, -1e38, 0.0, 1e38, 3e38, f32::MAX] {
                assert_eq!(table.set_of(v), rule(v), "{v} with the end at {end}");
            }
        }
    }

    #[test]
    fn without_ends_one_set_holds_everywhere() {
        let table = Regions::tabulate([], |_| 3);
        assert_eq!(table.set_of(-5.0), 3);
        assert_eq!(table.set_of(1e9), 3);
    }
}
