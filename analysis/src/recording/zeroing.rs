//! A session's zero record applied: each zeroed channel's offset
//! subtracted from its samples (taking the zero is [`crate::zero`]'s).

use acq_io::zero_record::{SensorZero, ZeroRecord};
use acq_rig::sensors::Sample;
use acq_rig::Rig;

/// A record's offsets, per rig sensor, ready to subtract.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Zeroing {
    offsets: Vec<Option<f64>>,
}

impl Zeroing {
    /// The offsets of `record` for `rig`'s sensors, matched by name.
    pub fn new(rig: &Rig, record: &ZeroRecord) -> Self {
        Zeroing {
            offsets: rig
                .sensors
                .iter()
                .map(|s| record.sensor(&s.name).map(SensorZero::offset))
                .collect(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.offsets.iter().all(Option::is_none)
    }

    /// The sample's value less its channel's zero.
    pub fn apply(&self, sample: &mut Sample) {
        if let (Some(Some(offset)), Some(value)) =
            (self.offsets.get(sample.sensor), sample.value.as_mut())
        {
            *value -= offset;
        }
    }
}
