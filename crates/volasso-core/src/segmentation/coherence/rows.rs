//! The majority filter's whole-row scans, in branch-free byte loops that vectorise: a row's
//! classified span, its voxels that disagree with a face neighbour, and those their votes keep.
//!
//! Never: decides a voxel's label; it only narrows the voxels the filter looks at.

/// The first and the last position of a non-zero label in `row`; `None` when it has none.
pub(super) fn classified_span(row: &[u8]) -> Option<(usize, usize)> {
    if row.iter().fold(0u8, |any, &label| any | label) == 0 {
        return None;
    }
    // A little-endian word's first label is its lowest byte.
    let word = |index: usize| u64::from_le_bytes(row[8 * index..][..8].try_into().unwrap_or_default());
    let words = row.len() / 8;
    let tail = &row[8 * words..];
    let first = match (0..words).find(|&index| word(index) != 0) {
        Some(index) => 8 * index + (word(index).trailing_zeros() / 8) as usize,
        None => 8 * words + tail.iter().position(|&label| label != 0)?,
    };
    let last = match tail.iter().rposition(|&label| label != 0) {
        Some(offset) => 8 * words + offset,
        None => {
            let index = (0..words).rev().find(|&index| word(index) != 0)?;
            8 * index + 7 - (word(index).leading_zeros() / 8) as usize
        }
    };
    Some((first, last))
}

/// Sets `flags` to 1 where a voxel of `row` is classified and a face neighbour (in the row or
/// the `neighbours` rows) holds another class, 0 elsewhere; background never disagrees.
pub(super) fn disagreeing_voxels(row: &[u8], neighbours: [Option<&[u8]>; 4], flags: &mut [u8]) {
    let disagrees = |own: u8, other: u8| u8::from(own != 0) & u8::from(other != 0) & u8::from(other != own);
    flags.fill(0);
    for neighbour in neighbours.into_iter().flatten() {
        for ((flag, &own), &other) in flags.iter_mut().zip(row).zip(neighbour) {
            *flag |= disagrees(own, other);
        }
    }
    let Some(last) = row.len().checked_sub(1) else { return };
    for ((flag, &own), &left) in flags[1..].iter_mut().zip(&row[1..]).zip(&row[..last]) {
        *flag |= disagrees(own, left);
    }
    for ((flag, &own), &right) in flags[..last].iter_mut().zip(&row[..last]).zip(&row[1..]) {
        *flag |= disagrees(own, right);
    }
}

/// A row's flags are cleared of unbeatable voxels ([`unflag_unbeatable`]) when at least 1 in
/// this many of its span is flagged; 1 in 4, 16 and 32 were no faster
/// (`docs/decisions/0009-majority-filter.md`).
pub(super) const ROW_COUNT_SHARE: usize = 8;

/// Clears the flag of each voxel of `row` (from `first` on) whose own label holds `unbeatable`
/// votes in `rows_around` (nine rows; `None` outside): the majority cannot change it.
pub(super) fn unflag_unbeatable(
    row: &[u8],
    first: usize,
    rows_around: &[Option<&[u8]>],
    flags: &mut [u8],
    votes: &mut [u8],
    unbeatable: u8,
) {
    let span = first..first + flags.len();
    votes.fill(0);
    // One vote where a voxel's own label equals the neighbour's at the same position in `other`.
    let count = |votes: &mut [u8], own: &[u8], other: &[u8]| {
        for ((vote, &own), &other) in votes.iter_mut().zip(own).zip(other) {
            *vote += u8::from(own == other);
        }
    };
    for neighbour in rows_around.iter().flatten() {
        // dx = 0; -1 (the voxel at x - 1 exists from x = 1 on); +1 (up to x = size_x - 2).
        count(votes, &row[span.clone()], &neighbour[span.clone()]);
        let left = span.start.max(1)..span.end;
        count(&mut votes[left.start - span.start..], &row[left.clone()], &neighbour[left.start - 1..]);
        let right = span.start..span.end.min(row.len() - 1);
        count(votes, &row[right.clone()], &neighbour[right.start + 1..]);
    }
    for (flag, &vote) in flags.iter_mut().zip(votes.iter()) {
        *flag &= u8::from(vote < unbeatable);
    }
}

/// Whether `row` and its `neighbours` rows hold only `label` or background: then no voxel of
/// `row` disagrees with a face neighbour.
pub(super) fn unopposed(row: &[u8], label: u8, neighbours: [Option<&[u8]>; 4]) -> bool {
    let agrees = |agrees: bool, &other: &u8| agrees & ((other == label) | (other == 0));
    row.iter().fold(true, agrees)
        && neighbours.into_iter().flatten().all(|neighbour| neighbour.iter().fold(true, agrees))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_s_classified_span_runs_from_its_first_to_its_last_label() {
        let mut rng = crate::rng::SplitMix64::new(7);
        for length in [0, 1, 7, 8, 9, 16, 17, 31, 301] {
            for _ in 0..50 {
                let mut row = vec![0u8; length];
                for _ in 0..rng.below(4) {
                    if length > 0 {
                        row[rng.below(length as u64) as usize] = 1 + rng.below(3) as u8;
                    }
                }
                let expected = row.iter().position(|&label| label != 0).zip(row.iter().rposition(|&label| label != 0));
                assert_eq!(classified_span(&row), expected, "{row:?}");
            }
        }
    }
}
