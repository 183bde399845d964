//! Whether training vectors can teach a classifier anything, asked before training: a value
//! that is not finite poisons the scatter matrices and the kernel, and classes whose vectors
//! are all one and the same vector give the SN-SVM nothing to separate (it then labels every
//! voxel with one class: a constant volume rendered as a solid box).
//!
//! Two vectors are the same when every feature differs by at most [`RELATIVE_TOLERANCE`] of
//! that feature's largest magnitude over the set: features are computed in f32, and a plane
//! mean of equal values may differ from the value in its last bit.
//!
//! Entry point: [`find_inseparable`]. Never: reads volumes, computes or standardises features.

/// Features closer than this, relative to the feature's largest magnitude, are equal.
pub const RELATIVE_TOLERANCE: f32 = 1e-5;

/// What makes a training set unlearnable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inseparable {
    /// Sample `sample` has a NaN or infinite value at `feature`.
    NotFinite {
        /// The sample (row).
        sample: usize,
        /// The feature (column).
        feature: usize,
    },
    /// Every sample of every class is the same vector (that of sample 0).
    AllEqual,
    /// Every sample of class `first` and of class `second` is the same vector.
    SameVectors {
        /// The smaller class id.
        first: u8,
        /// The larger class id.
        second: u8,
    },
}

/// The first reason why `values` (rows of `dim` features) labelled `labels` (one class id a
/// row) cannot train a classifier, or `None` when they can.
pub fn find_inseparable(values: &[f32], dim: usize, labels: &[u8]) -> Option<Inseparable> {
    if dim == 0 || values.is_empty() {
        return None;
    }
    if let Some(position) = values.iter().position(|v| !v.is_finite()) {
        return Some(Inseparable::NotFinite { sample: position / dim, feature: position % dim });
    }
    let rows: Vec<&[f32]> = values.chunks_exact(dim).collect();
    let mut largest = vec![0f32; dim];
    for row in &rows {
        for (largest, value) in largest.iter_mut().zip(row.iter()) {
            *largest = largest.max(value.abs());
        }
    }
    let same = |a: &[f32], b: &[f32]| {
        a.iter().zip(b).zip(&largest).all(|((a, b), largest)| (a - b).abs() <= RELATIVE_TOLERANCE * largest)
    };
    if rows.iter().all(|row| same(row, rows[0])) {
        return Some(Inseparable::AllEqual);
    }
    // Each class's one vector, when all its samples are the same.
    let mut classes: Vec<u8> = labels.to_vec();
    classes.sort_unstable();
    classes.dedup();
    let constant: Vec<(u8, &[f32])> = classes
        .iter()
        .filter_map(|&class| {
            let mut members = rows.iter().zip(labels).filter(|(_, label)| **label == class).map(|(row, _)| *row);
            let first = members.next()?;
            members.all(|row| same(row, first)).then_some((class, first))
        })
        .collect();
    for (k, &(first, a)) in constant.iter().enumerate() {
        if let Some(&(second, _)) = constant[k + 1..].iter().find(|(_, b)| same(a, b)) {
            return Some(Inseparable::SameVectors { first, second });
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_vector_for_every_sample_cannot_be_separated() {
        // A constant volume: intensity 100, no gradient, plane means 100 (one a bit off).
        let values = [100.0, 0.0, 100.0, 100.0, 0.0, 100.00001, 100.0, 0.0, 100.0];
        assert_eq!(find_inseparable(&values, 3, &[1, 2, 2]), Some(Inseparable::AllEqual));
        let zeros = [0.0f32; 8];
        assert_eq!(find_inseparable(&zeros, 2, &[1, 1, 2, 3]), Some(Inseparable::AllEqual));
    }

    #[test]
    fn two_classes_of_one_vector_each_cannot_be_told_apart() {
        // Classes 1 and 3 lasso the same flat material; class 2 varies.
        let values = [5.0, 1.0, 5.0, 1.0, 9.0, 2.0, 9.5, 2.5, 5.0, 1.0];
        assert_eq!(
            find_inseparable(&values, 2, &[1, 1, 2, 2, 3]),
            Some(Inseparable::SameVectors { first: 1, second: 3 })
        );
        // A class of one vector beside a class of another is fine.
        assert_eq!(find_inseparable(&values[..8], 2, &[1, 1, 2, 2]), None);
        assert_eq!(find_inseparable(&[5.0, 1.0, 6.0, 1.0], 2, &[1, 2]), None);
    }

    #[test]
    fn a_value_that_is_not_finite_is_found_first() {
        let values = [1.0, 2.0, 3.0, f32::INFINITY, 1.0, f32::NAN];
        assert_eq!(find_inseparable(&values, 3, &[1, 2]), Some(Inseparable::NotFinite { sample: 1, feature: 0 }));
    }
}
