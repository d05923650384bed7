//! Which sample indices a render renders: `first, first + step, …`, `count` of them — all of
//! 0..spp, one shard's (s ≡ I mod N), or what an interrupted render has left. Held as three
//! numbers, never as a list, so a render's memory does not grow with its sample count.

use serde::{Deserialize, Serialize};

/// An arithmetic sequence of sample indices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SampleSequence {
    pub first: u32,
    pub step: u32,
    pub count: u32,
}

impl SampleSequence {
    /// 0, 1, …, spp − 1.
    pub fn all(spp: u32) -> SampleSequence {
        SampleSequence {
            first: 0,
            step: 1,
            count: spp,
        }
    }

    /// `first`, `first + step`, … below `end`.
    pub fn every(first: u32, step: u32, end: u32) -> SampleSequence {
        let step = step.max(1);
        let count = if first < end {
            (end - first - 1) / step + 1
        } else {
            0
        };
        SampleSequence { first, step, count }
    }

    /// The sequence of `indices` if they are one (increasing, evenly spaced).
    pub fn from_list(indices: &[u32]) -> Option<SampleSequence> {
        let (&first, rest) = match indices.split_first() {
            Some(split) => split,
            None => return Some(SampleSequence::all(0)),
        };
        let step = rest
            .first()
            .map_or(Some(1), |&second| second.checked_sub(first))?;
        let sequence = SampleSequence {
            first,
            step,
            count: u32::try_from(indices.len()).ok()?,
        };
        (step > 0 && sequence.iter().eq(indices.iter().copied())).then_some(sequence)
    }

    pub fn len(&self) -> usize {
        self.count as usize
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Index `k` (< len) of the sequence.
    pub fn get(&self, k: u32) -> u32 {
        debug_assert!(k < self.count);
        (self.first as u64 + k as u64 * self.step as u64) as u32
    }

    /// What is left once the first `done` are rendered.
    pub fn after(&self, done: u32) -> SampleSequence {
        let done = done.min(self.count);
        if done == self.count {
            return SampleSequence { count: 0, ..*self };
        }
        SampleSequence {
            first: self.get(done),
            step: self.step,
            count: self.count - done,
        }
    }

    /// The first `n` indices (all of them when there are fewer).
    pub fn first_n(&self, n: u32) -> SampleSequence {
        SampleSequence {
            count: self.count.min(n),
            ..*self
        }
    }

    pub fn iter(&self) -> impl ExactSizeIterator<Item = u32> + use<> {
        let sequence = *self;
        (0..sequence.count).map(move |k| sequence.get(k))
    }

    /// The indices as a list, for a checkpoint's record.
    pub fn to_vec(&self) -> Vec<u32> {
        self.iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequences_list_their_indices() {
        assert_eq!(SampleSequence::all(4).to_vec(), [0, 1, 2, 3]);
        assert_eq!(SampleSequence::every(1, 3, 10).to_vec(), [1, 4, 7]);
        assert_eq!(SampleSequence::every(2, 3, 10).to_vec(), [2, 5, 8]);
        assert!(SampleSequence::every(5, 8, 5).is_empty());
        let shard = SampleSequence::every(1, 3, 10);
        assert_eq!(shard.after(1).to_vec(), [4, 7]);
        assert!(shard.after(3).is_empty() && shard.after(9).is_empty());
        // The largest: every index of u32 fits, with no overflow at the end.
        let huge = SampleSequence::every(u32::MAX - 1, 1, u32::MAX);
        assert_eq!(huge.to_vec(), [u32::MAX - 1]);
        assert_eq!(SampleSequence::all(u32::MAX).len(), u32::MAX as usize);
        assert_eq!(
            SampleSequence::all(u32::MAX).after(u32::MAX - 1).to_vec(),
            [u32::MAX - 1]
        );
    }

    #[test]
    fn lists_that_are_sequences_are_recognised() {
        for sequence in [
            SampleSequence::all(0),
            SampleSequence::all(5),
            SampleSequence::every(7, 4, 30),
            SampleSequence::every(9, 4, 10),
        ] {
            let list = sequence.to_vec();
            let found = SampleSequence::from_list(&list).expect("a sequence");
            assert_eq!(found.to_vec(), list);
        }
        for not in [&[3, 2][..], &[1, 2, 4], &[5, 5], &[0, 2, 3]] {
            assert_eq!(SampleSequence::from_list(not), None, "{not:?}");
        }
    }
}
