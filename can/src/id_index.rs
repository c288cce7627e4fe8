//! Places by CAN id, for the lookups made once per frame: an 11-bit id's
//! in a flat table (an index, no hashing: standard ids are the common
//! case), any other's in a map. The DBC database finds a frame's message
//! through one; the rig's decoder finds a frame's sensors through one a bus.

use rustc_hash::FxHashMap;

use crate::frame::{CanId, MAX_STANDARD_ID};

/// A place (a `u32` below `u32::MAX`: an index into the owner's list)
/// for each id it was given.
#[derive(Clone, Debug, Default)]
pub struct IdIndex {
    /// By 11-bit id, [`NONE`] where there is none; empty until the first.
    standard: Vec<u32>,
    /// By [`CanId::key`]: 29-bit ids.
    others: FxHashMap<u32, u32>,
}

/// Not a place: an id without one.
const NONE: u32 = u32::MAX;

impl IdIndex {
    pub fn new() -> Self {
        Self::default()
    }

    /// The place of `id`, if it has one.
    #[inline]
    pub fn get(&self, id: CanId) -> Option<u32> {
        let place = match id {
            CanId::Standard(raw) if raw <= MAX_STANDARD_ID => {
                *self.standard.get(usize::from(raw))?
            }
            _ => *self.others.get(&id.key())?,
        };
        (place != NONE).then_some(place)
    }

    /// Gives `id` the place `place`, replacing one it had (`u32::MAX`:
    /// none).
    pub fn insert(&mut self, id: CanId, place: u32) {
        match id {
            CanId::Standard(raw) if raw <= MAX_STANDARD_ID => {
                if self.standard.is_empty() {
                    self.standard = vec![NONE; usize::from(MAX_STANDARD_ID) + 1];
                }
                self.standard[usize::from(raw)] = place;
            }
            _ => {
                self.others.insert(id.key(), place);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_id_keeps_its_place_and_the_last_one_given_wins() {
        let mut index = IdIndex::new();
        let standard = CanId::standard(0x123).unwrap();
        let extended = CanId::extended(0x123).unwrap();
        assert_eq!(index.get(standard), None);
        index.insert(standard, 4);
        index.insert(extended, 7);
        assert_eq!(index.get(standard), Some(4));
        assert_eq!(index.get(extended), Some(7));
        assert_eq!(index.get(CanId::standard(0x7FF).unwrap()), None);
        index.insert(standard, 9);
        assert_eq!(index.get(standard), Some(9));
    }
}
