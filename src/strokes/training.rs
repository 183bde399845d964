//! Training voxels per class from a strokes file, and a stratified cap on their number.
//!
//! Within a class a voxel selected by several strokes counts once, for the first of them.
//! A voxel selected by two or more *classes* is contested: it is dropped from all of them
//! (counted in [`TrainingSet::contested_voxels`] and logged as a warning), because a sample
//! labelled twice teaches the classifier nothing and would make its classes overlap. This
//! rule does not depend on the order of the classes.

use super::{StrokesError, StrokesFile};
use crate::rng::{SplitMix64, hash64};

/// How a class's share of the training cap follows its size ([`TrainingSet::capped`]): a class
/// drawn at a sixteenth of the largest one's voxels keeps up to half as many. The SN-SVM weighs
/// its classes by their training voxels, so where classes overlap in features (a bone's
/// blurred edge, a joint space's partial volume) the larger class should keep the larger say:
/// with the same number of voxels for every class (exponent 0) a thin class the user drew with
/// a few hundred voxels claimed the blurred edges of the structures around it (a knee's joint
/// space); in proportion to the drawn voxels (exponent 1) a small class lost its own blurred
/// edge to its surroundings (an aorta, cell nuclei and granules in a noisy MRI). Measured on
/// `scripts/heldout.py` among 0, 1/5, 1/4, 1/3, 1/2 and 1 (benches/README.md); the accuracy
/// harness's lassos stay under the cap and do not tell them apart.
pub const CAP_SIZE_EXPONENT: f64 = 0.25;

/// The training voxels of one class.
#[derive(Clone, Debug, PartialEq)]
pub struct ClassSamples {
    /// The class's name, as in the strokes file.
    pub name: String,
    /// Volume indices (x fastest), sorted and unique.
    pub voxels: Vec<usize>,
    /// For each of `voxels`, the position in the class's strokes of the stroke it came from.
    pub stroke_of_voxel: Vec<u32>,
    /// Voxels kept from each stroke of the class (after contested voxels and any cap).
    pub stroke_voxel_counts: Vec<usize>,
    /// Voxels a cap ([`TrainingSet::capped`]) removed from this class.
    pub dropped_by_cap: usize,
}

/// Training voxels per class; class id k (1-based, the label the classifier uses) is
/// `classes[k - 1]`.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainingSet {
    /// Each class's samples, in the strokes file's order.
    pub classes: Vec<ClassSamples>,
    /// Voxels selected by more than one class, removed from all of them.
    pub contested_voxels: usize,
}

impl TrainingSet {
    /// The training voxels of `file` in a volume of `dims`. Checks the file against the volume,
    /// refuses a file without classes ([`StrokesError::NoClasses`]), a class whose lassos
    /// select nothing ([`StrokesError::EmptyClass`]) and one whose every voxel another class
    /// also selects ([`StrokesError::Overlapped`]).
    pub fn from_strokes(file: &StrokesFile, dims: [usize; 3]) -> Result<TrainingSet, StrokesError> {
        if file.classes.is_empty() {
            return Err(StrokesError::NoClasses);
        }
        let (set, overlapped_by) = TrainingSet::build(file, dims)?;
        if let Some((position, &Some(other))) = overlapped_by.iter().enumerate().find(|(_, by)| by.is_some()) {
            return Err(StrokesError::Overlapped {
                class: set.classes[position].name.clone(),
                class_id: position + 1,
                other: set.classes[other].name.clone(),
                other_id: other + 1,
            });
        }
        set.check_every_class_has_voxels()?;
        Ok(set)
    }

    /// As [`from_strokes`](Self::from_strokes), but a class may end up without voxels (a
    /// caller that builds the set while the user is still drawing).
    pub fn from_strokes_keeping_empty(file: &StrokesFile, dims: [usize; 3]) -> Result<TrainingSet, StrokesError> {
        TrainingSet::build(file, dims).map(|(set, _)| set)
    }

    /// The set, and for each class that only contested voxels emptied, the position of the
    /// first other class that selects one of them.
    fn build(file: &StrokesFile, dims: [usize; 3]) -> Result<(TrainingSet, Vec<Option<usize>>), StrokesError> {
        file.check_for_volume(dims)?;
        let mut classes: Vec<ClassSamples> = file
            .classes
            .iter()
            .map(|class| {
                let mut tagged: Vec<(usize, u32)> = Vec::new();
                for (stroke, lasso) in class.strokes.iter().enumerate() {
                    tagged.extend(lasso.selected_voxels(dims).into_iter().map(|v| (v, stroke as u32)));
                }
                // Sorting by (voxel, stroke) and keeping the first of each voxel gives it to
                // its first stroke.
                tagged.sort_unstable();
                tagged.dedup_by_key(|&mut (voxel, _)| voxel);
                let (voxels, stroke_of_voxel) = tagged.into_iter().unzip();
                ClassSamples {
                    name: class.name.clone(),
                    voxels,
                    stroke_of_voxel,
                    stroke_voxel_counts: vec![0; class.strokes.len()],
                    dropped_by_cap: 0,
                }
            })
            .collect();
        let mut overlapped_by = vec![None; classes.len()];
        let contested = contested_voxels(&classes);
        if !contested.is_empty() {
            log::warn!("{} voxels are selected by more than one class; they are left out of training", contested.len());
            let selected: Vec<Vec<usize>> = classes.iter().map(|c| c.voxels.clone()).collect();
            for (position, class) in classes.iter_mut().enumerate() {
                let (voxels, strokes): (Vec<usize>, Vec<u32>) = class
                    .voxels
                    .iter()
                    .zip(&class.stroke_of_voxel)
                    .filter(|(voxel, _)| contested.binary_search(voxel).is_err())
                    .unzip();
                if voxels.is_empty() && !class.voxels.is_empty() {
                    let shares = |other: &Vec<usize>| class.voxels.iter().any(|v| other.binary_search(v).is_ok());
                    overlapped_by[position] =
                        selected.iter().enumerate().position(|(k, other)| k != position && shares(other));
                }
                class.voxels = voxels;
                class.stroke_of_voxel = strokes;
            }
        }
        for class in &mut classes {
            class.count_per_stroke();
        }
        Ok((TrainingSet { classes, contested_voxels: contested.len() }, overlapped_by))
    }

    /// `Err(EmptyClass)` naming the first class without voxels.
    pub fn check_every_class_has_voxels(&self) -> Result<(), StrokesError> {
        match self.classes.iter().position(|c| c.voxels.is_empty()) {
            Some(position) => {
                Err(StrokesError::EmptyClass { class: self.classes[position].name.clone(), class_id: position + 1 })
            }
            None => Ok(()),
        }
    }

    /// Training voxels over all classes.
    pub fn voxel_count(&self) -> usize {
        self.classes.iter().map(|c| c.voxels.len()).sum()
    }

    /// The set with each class whose entry in `only` is `Some(voxels)` (sorted) reduced to its
    /// voxels that `voxels` holds; a class that would be left without any keeps all of its own.
    pub fn restricted(&self, only: &[Option<&[usize]>]) -> TrainingSet {
        let classes = self
            .classes
            .iter()
            .zip(only.iter().chain(std::iter::repeat(&None)))
            .map(|(class, only)| match only {
                Some(only) => {
                    let keep: Vec<bool> = class.voxels.iter().map(|voxel| only.binary_search(voxel).is_ok()).collect();
                    if keep.contains(&true) { class.retaining(&keep) } else { class.clone() }
                }
                None => class.clone(),
            })
            .collect();
        TrainingSet { classes, contested_voxels: self.contested_voxels }
    }

    /// Every training voxel with its class id (1-based), class by class.
    pub fn labelled_voxels(&self) -> (Vec<usize>, Vec<u8>) {
        let mut voxels = Vec::with_capacity(self.voxel_count());
        let mut labels = Vec::with_capacity(self.voxel_count());
        for (position, class) in self.classes.iter().enumerate() {
            voxels.extend_from_slice(&class.voxels);
            // from_strokes refuses more than 255 classes.
            labels.extend(std::iter::repeat_n((position + 1) as u8, class.voxels.len()));
        }
        (voxels, labels)
    }

    /// At most `max_per_class` voxels per class, drawn at random (seeded, so deterministic)
    /// and stratified over the class's strokes: each stroke keeps its share of the class,
    /// rounded by largest remainder. The largest class keeps up to `max_per_class`, and a
    /// class of n voxels keeps up to that times (n / the largest's count) to the power
    /// [`CAP_SIZE_EXPONENT`] (at least one voxel): the classes keep the order of the sizes the
    /// user drew them at. Classes already within their share are unchanged; `dropped_by_cap`
    /// says how many went.
    pub fn capped(&self, max_per_class: usize, seed: u64) -> TrainingSet {
        let largest = self.classes.iter().map(|class| class.voxels.len()).max().unwrap_or(0);
        let kept_by_largest = max_per_class.min(largest) as f64;
        let classes = self
            .classes
            .iter()
            .enumerate()
            .map(|(position, class)| {
                let count = class.voxels.len();
                let share = (count as f64 / largest.max(1) as f64).powf(CAP_SIZE_EXPONENT);
                let cap = ((kept_by_largest * share).round() as usize).max(count.min(1));
                class.capped(cap, hash64(seed, position as u64))
            })
            .collect();
        TrainingSet { classes, contested_voxels: self.contested_voxels }
    }
}

impl ClassSamples {
    /// A class named `name` of `voxels` (volume indices, sorted and unique), all from one
    /// stroke: scribbles painted into a label volume, or a box in a test.
    pub fn one_stroke(name: String, voxels: Vec<usize>) -> ClassSamples {
        ClassSamples {
            name,
            stroke_of_voxel: vec![0; voxels.len()],
            stroke_voxel_counts: vec![voxels.len()],
            voxels,
            dropped_by_cap: 0,
        }
    }

    fn count_per_stroke(&mut self) {
        self.stroke_voxel_counts.iter_mut().for_each(|c| *c = 0);
        for &stroke in &self.stroke_of_voxel {
            self.stroke_voxel_counts[stroke as usize] += 1;
        }
    }

    /// The class with only the voxels where `keep` (one flag per voxel) holds; the strokes'
    /// counts follow, the cap's count is kept.
    pub fn retaining(&self, keep: &[bool]) -> ClassSamples {
        let (voxels, stroke_of_voxel): (Vec<usize>, Vec<u32>) = self
            .voxels
            .iter()
            .zip(&self.stroke_of_voxel)
            .zip(keep)
            .filter(|(_, keep)| **keep)
            .map(|((&voxel, &stroke), _)| (voxel, stroke))
            .unzip();
        let mut retained = ClassSamples {
            name: self.name.clone(),
            voxels,
            stroke_of_voxel,
            stroke_voxel_counts: vec![0; self.stroke_voxel_counts.len()],
            dropped_by_cap: self.dropped_by_cap,
        };
        retained.count_per_stroke();
        retained
    }

    fn capped(&self, max_per_class: usize, seed: u64) -> ClassSamples {
        let total = self.voxels.len();
        if total <= max_per_class {
            return self.clone();
        }
        let quotas = largest_remainder_quotas(&self.stroke_voxel_counts, max_per_class);
        let mut rng = SplitMix64::new(seed);
        let mut kept: Vec<(usize, u32)> = Vec::with_capacity(max_per_class);
        for (stroke, &quota) in quotas.iter().enumerate() {
            let mut members: Vec<usize> = self
                .voxels
                .iter()
                .zip(&self.stroke_of_voxel)
                .filter(|&(_, &s)| s as usize == stroke)
                .map(|(&voxel, _)| voxel)
                .collect();
            rng.partial_shuffle(&mut members, quota);
            kept.extend(members[..quota].iter().map(|&voxel| (voxel, stroke as u32)));
        }
        kept.sort_unstable();
        let (voxels, stroke_of_voxel): (Vec<usize>, Vec<u32>) = kept.into_iter().unzip();
        let mut capped = ClassSamples {
            name: self.name.clone(),
            dropped_by_cap: self.dropped_by_cap + total - voxels.len(),
            voxels,
            stroke_of_voxel,
            stroke_voxel_counts: self.stroke_voxel_counts.clone(),
        };
        capped.count_per_stroke();
        capped
    }
}

/// Splits `target` (< the sum of `counts`) in proportion to `counts`: floors first, then one
/// more to the largest fractional parts (ties to the earlier stroke).
fn largest_remainder_quotas(counts: &[usize], target: usize) -> Vec<usize> {
    let total: usize = counts.iter().sum();
    if total == 0 {
        return vec![0; counts.len()];
    }
    // Exact integer arithmetic: share = count * target / total.
    let mut quotas: Vec<usize> =
        counts.iter().map(|&c| ((c as u128 * target as u128) / total as u128) as usize).collect();
    let remainders: Vec<u128> = counts.iter().map(|&c| (c as u128 * target as u128) % total as u128).collect();
    let mut order: Vec<usize> = (0..counts.len()).collect();
    order.sort_by(|&a, &b| remainders[b].cmp(&remainders[a]).then(a.cmp(&b)));
    let missing = target.saturating_sub(quotas.iter().sum());
    for &stroke in order.iter().take(missing) {
        quotas[stroke] += 1;
    }
    quotas
}

/// Voxels that appear in more than one class, sorted.
fn contested_voxels(classes: &[ClassSamples]) -> Vec<usize> {
    let mut all: Vec<usize> = classes.iter().flat_map(|c| c.voxels.iter().copied()).collect();
    all.sort_unstable();
    // Each class's voxels are unique, so a repeat means two classes.
    let mut contested: Vec<usize> = all.windows(2).filter(|w| w[0] == w[1]).map(|w| w[0]).collect();
    contested.dedup();
    contested
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slices::Axis;
    use crate::strokes::{ClassStrokes, Lasso};

    const DIMS: [usize; 3] = [40, 30, 20];

    /// An axis-aligned rectangle of centres x0..=x1, y0..=y1 on z slice `z`.
    fn rectangle(z: usize, x0: usize, y0: usize, x1: usize, y1: usize) -> Lasso {
        let (x0, y0, x1, y1) = (x0 as f64 - 0.5, y0 as f64 - 0.5, x1 as f64 + 0.5, y1 as f64 + 0.5);
        Lasso { axis: Axis::Z, slice: z, points: vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]] }
    }

    fn class(name: &str, strokes: Vec<Lasso>) -> ClassStrokes {
        ClassStrokes { name: name.into(), strokes }
    }

    #[test]
    fn a_restricted_set_keeps_the_listed_voxels_and_never_empties_a_class() {
        let set = TrainingSet {
            classes: vec![
                ClassSamples::one_stroke("a".into(), vec![1, 2, 3, 4]),
                ClassSamples::one_stroke("b".into(), vec![10, 11]),
                ClassSamples::one_stroke("c".into(), vec![20, 21]),
            ],
            contested_voxels: 0,
        };
        let restricted = set.restricted(&[Some(&[2, 3, 99]), None, Some(&[5])]);
        let voxels: Vec<&[usize]> = restricted.classes.iter().map(|c| c.voxels.as_slice()).collect();
        assert_eq!(voxels, [&[2, 3][..], &[10, 11], &[20, 21]]);
        assert_eq!(restricted.classes[0].stroke_voxel_counts, vec![2]);
    }

    #[test]
    fn voxels_claimed_by_two_classes_are_dropped_from_both() {
        let file = StrokesFile {
            classes: vec![
                // 10 x 10 (x, y 0..=9) and 5 x 10 (x 5..=9, y 2..=11): 110 voxels in all.
                class("bone", vec![rectangle(5, 0, 0, 9, 9), rectangle(5, 5, 2, 9, 11)]),
                // x 8..=11, y 0..=9: its columns 8 and 9 overlap bone's first stroke.
                class("soft tissue", vec![rectangle(5, 8, 0, 11, 9)]),
            ],
        };
        let set = TrainingSet::from_strokes(&file, DIMS).unwrap();
        assert_eq!(set.contested_voxels, 20);
        let bone = &set.classes[0];
        assert_eq!(bone.voxels.len(), 110 - 20);
        // The second stroke keeps only rows 10 and 11; the rest went to the first stroke.
        assert_eq!(bone.stroke_voxel_counts, vec![80, 10]);
        assert!(bone.voxels.windows(2).all(|w| w[0] < w[1]));
        let soft = &set.classes[1];
        assert_eq!(soft.voxels.len(), 40 - 20);
        for voxel in &soft.voxels {
            assert!(bone.voxels.binary_search(voxel).is_err());
            assert!([10, 11].contains(&(voxel % 40)));
        }
        // Within a class, an overlap counts once, for the first stroke.
        let first_stroke_voxel = 6 + 40 * (3 + 30 * 5);
        let position = bone.voxels.binary_search(&first_stroke_voxel).unwrap();
        assert_eq!(bone.stroke_of_voxel[position], 0);
        let (voxels, labels) = set.labelled_voxels();
        assert_eq!(voxels.len(), 110);
        assert_eq!(labels.iter().filter(|&&l| l == 2).count(), 20);
        assert_eq!(labels[0], 1);
    }

    #[test]
    fn a_class_whose_lassos_select_nothing_is_an_error_naming_it() {
        let file = StrokesFile {
            classes: vec![
                class("bone", vec![rectangle(1, 0, 0, 3, 3)]),
                class("joint", vec![Lasso { axis: Axis::Y, slice: 2, points: vec![[1.0, 1.0], [2.0, 2.0]] }]),
            ],
        };
        let error = TrainingSet::from_strokes(&file, DIMS).unwrap_err();
        assert!(matches!(&error, StrokesError::EmptyClass { class, class_id: 2 } if class == "joint"));
        assert!(error.to_string().contains("'joint'"));
        let kept = TrainingSet::from_strokes_keeping_empty(&file, DIMS).unwrap();
        assert!(kept.classes[1].voxels.is_empty());
        assert_eq!(kept.classes[1].stroke_voxel_counts, vec![0]);
    }

    #[test]
    fn a_class_inside_another_class_names_the_other_and_no_class_is_its_own_error() {
        let file = StrokesFile {
            classes: vec![
                class("bone", vec![rectangle(1, 0, 0, 9, 9)]),
                // Wholly inside bone's lasso: every voxel is contested.
                class("marrow", vec![rectangle(1, 2, 2, 4, 4)]),
            ],
        };
        let error = TrainingSet::from_strokes(&file, DIMS).unwrap_err();
        assert!(
            matches!(&error, StrokesError::Overlapped { class, class_id: 2, other, other_id: 1 } if class == "marrow" && other == "bone"),
            "{error:?}"
        );
        let message = error.to_string();
        assert!(message.contains("class 2 'marrow' select only voxels that class 1 'bone' also selects"), "{message}");
        // Bone keeps voxels outside marrow: only marrow is refused.
        let kept = TrainingSet::from_strokes_keeping_empty(&file, DIMS).unwrap();
        assert_eq!((kept.classes[0].voxels.len(), kept.classes[1].voxels.len()), (100 - 9, 0));
        let none = TrainingSet::from_strokes(&StrokesFile::default(), DIMS).unwrap_err();
        assert!(matches!(none, StrokesError::NoClasses));
        assert_eq!(none.to_string(), "the strokes file defines no class");
    }

    #[test]
    fn slices_outside_the_volume_and_too_many_classes_are_refused() {
        let file = StrokesFile { classes: vec![class("a", vec![rectangle(20, 0, 0, 3, 3)])] };
        assert!(matches!(
            TrainingSet::from_strokes(&file, DIMS),
            Err(StrokesError::SliceOutOfRange { slice: 20, slice_count: 20, .. })
        ));
        let many = StrokesFile { classes: (0..256).map(|k| class(&k.to_string(), vec![])).collect() };
        assert!(matches!(TrainingSet::from_strokes(&many, DIMS), Err(StrokesError::TooManyClasses { count: 256 })));
    }

    #[test]
    fn a_cap_keeps_each_strokes_share_and_is_deterministic() {
        let file = StrokesFile {
            classes: vec![
                // 300 and 100 voxels on different slices, and a small class under the cap.
                class("bone", vec![rectangle(1, 0, 0, 29, 9), rectangle(2, 0, 0, 9, 9)]),
                class("air", vec![rectangle(3, 0, 0, 4, 4)]),
            ],
        };
        let set = TrainingSet::from_strokes(&file, DIMS).unwrap();
        let capped = set.capped(101, 7);
        let bone = &capped.classes[0];
        assert_eq!(bone.voxels.len(), 101);
        // 101 * 3/4 = 75.75, 101 / 4 = 25.25: the larger remainder gets the extra voxel.
        assert_eq!(bone.stroke_voxel_counts, vec![76, 25]);
        assert_eq!(bone.dropped_by_cap, 299);
        assert!(bone.voxels.windows(2).all(|w| w[0] < w[1]));
        assert!(bone.voxels.iter().all(|v| set.classes[0].voxels.binary_search(v).is_ok()));
        for (voxel, &stroke) in bone.voxels.iter().zip(&bone.stroke_of_voxel) {
            assert_eq!(voxel / (40 * 30), stroke as usize + 1);
        }
        assert_eq!(capped.classes[1], set.classes[1]);
        assert_eq!(set.capped(101, 7), capped);
        assert_ne!(set.capped(101, 8).classes[0].voxels, bone.voxels);
        assert_eq!(set.capped(1000, 7), set);
    }

    #[test]
    fn a_cap_keeps_the_classes_in_the_order_of_their_sizes() {
        let file = StrokesFile {
            classes: vec![
                class("bone", vec![rectangle(1, 0, 0, 39, 24)]), // 1000 voxels
                class("joint", vec![rectangle(2, 0, 0, 24, 4)]), // 125
                class("marrow", vec![rectangle(3, 0, 0, 9, 0)]), // 10
            ],
        };
        let set = TrainingSet::from_strokes(&file, DIMS).unwrap();
        let counts: Vec<usize> = set.classes.iter().map(|c| c.voxels.len()).collect();
        assert_eq!(counts, vec![1000, 125, 10]);
        let capped = set.capped(100, 7);
        let kept: Vec<usize> = capped.classes.iter().map(|c| c.voxels.len()).collect();
        // An eighth of the largest class's voxels keeps 100 * (1/8)^(1/4), 59; 10 voxels are
        // within 100 * (1/100)^(1/4), 32.
        let expected = (100.0 * 0.125f64.powf(CAP_SIZE_EXPONENT)).round() as usize;
        assert_eq!(kept, vec![100, expected, 10]);
        assert!(expected < 100 && expected > 10);
        assert_eq!(capped.classes[1].dropped_by_cap, 125 - expected);
        assert_eq!(set.capped(1000, 7), set, "within the cap nothing changes");
        let one = set.capped(1, 7);
        assert!(one.classes.iter().all(|c| c.voxels.len() == 1), "every class keeps a voxel");
    }

    #[test]
    fn largest_remainder_quotas_add_up_to_the_target() {
        assert_eq!(largest_remainder_quotas(&[1, 1, 1], 2), vec![1, 1, 0]);
        assert_eq!(largest_remainder_quotas(&[0, 10, 5], 6), vec![0, 4, 2]);
        assert_eq!(largest_remainder_quotas(&[0, 0], 3), vec![0, 0]);
        for target in 0..50 {
            let quotas = largest_remainder_quotas(&[7, 13, 29, 1], target);
            assert_eq!(quotas.iter().sum::<usize>(), target);
        }
    }
}
