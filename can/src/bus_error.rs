//! What an error frame says about the bus: the `CAN_ERR_*` classes of
//! `linux/can/error.h` and the controller status in data byte 1, reduced to
//! the states a test engineer acts on (bus-off, error-passive, overflow).

use crate::frame::{Frame, FrameKind};

const CAN_ERR_TX_TIMEOUT: u32 = 0x001;
const CAN_ERR_LOSTARB: u32 = 0x002;
const CAN_ERR_CRTL: u32 = 0x004;
const CAN_ERR_PROT: u32 = 0x008;
const CAN_ERR_TRX: u32 = 0x010;
const CAN_ERR_ACK: u32 = 0x020;
const CAN_ERR_BUSOFF: u32 = 0x040;
const CAN_ERR_BUSERROR: u32 = 0x080;
const CAN_ERR_RESTARTED: u32 = 0x100;
const CAN_ERR_CNT: u32 = 0x200;

const CAN_ERR_CRTL_RX_OVERFLOW: u8 = 0x01;
const CAN_ERR_CRTL_TX_OVERFLOW: u8 = 0x02;
const CAN_ERR_CRTL_RX_WARNING: u8 = 0x04;
const CAN_ERR_CRTL_TX_WARNING: u8 = 0x08;
const CAN_ERR_CRTL_RX_PASSIVE: u8 = 0x10;
const CAN_ERR_CRTL_TX_PASSIVE: u8 = 0x20;

/// The meaning of one error frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BusErrorReport {
    pub bus_off: bool,
    pub error_passive: bool,
    pub error_warning: bool,
    /// The controller's receive or transmit buffer overflowed: frames lost
    /// in hardware, before the kernel saw them.
    pub controller_overflow: bool,
    /// Protocol violation, missing ACK, transceiver or bus error.
    pub bus_error: bool,
    pub tx_timeout: bool,
    pub lost_arbitration: bool,
    pub restarted: bool,
    /// (transmit, receive) error counters, when the driver reports them.
    pub error_counters: Option<(u8, u8)>,
}

impl BusErrorReport {
    /// Reads an error frame; `None` for any other kind of frame.
    pub fn from_frame(frame: &Frame) -> Option<Self> {
        let FrameKind::Error { class } = frame.kind else {
            return None;
        };
        let data = frame.payload();
        let byte = |i: usize| data.get(i).copied().unwrap_or(0);
        let controller = if class & CAN_ERR_CRTL != 0 {
            byte(1)
        } else {
            0
        };
        Some(BusErrorReport {
            bus_off: class & CAN_ERR_BUSOFF != 0,
            error_passive: controller & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE) != 0,
            error_warning: controller & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING) != 0,
            controller_overflow: controller & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW)
                != 0,
            bus_error: class & (CAN_ERR_PROT | CAN_ERR_TRX | CAN_ERR_ACK | CAN_ERR_BUSERROR) != 0,
            tx_timeout: class & CAN_ERR_TX_TIMEOUT != 0,
            lost_arbitration: class & CAN_ERR_LOSTARB != 0,
            restarted: class & CAN_ERR_RESTARTED != 0,
            error_counters: (class & CAN_ERR_CNT != 0).then(|| (byte(6), byte(7))),
        })
    }

    /// A short human description, e.g. `bus-off`, `error-passive, overflow`.
    pub fn describe(&self) -> String {
        let names = [
            (self.bus_off, "bus-off"),
            (self.error_passive, "error-passive"),
            (self.error_warning, "error-warning"),
            (self.controller_overflow, "controller overflow"),
            (self.bus_error, "bus error"),
            (self.tx_timeout, "tx timeout"),
            (self.lost_arbitration, "lost arbitration"),
            (self.restarted, "restarted"),
        ];
        let parts: Vec<&str> = names
            .iter()
            .filter(|(on, _)| *on)
            .map(|(_, n)| *n)
            .collect();
        if parts.is_empty() {
            "unspecified error".to_owned()
        } else {
            parts.join(", ")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{CanId, IfaceName};

    fn error(class: u32, data: &[u8]) -> Frame {
        Frame::error(0, IfaceName::new("can0").unwrap(), class, data).unwrap()
    }

    #[test]
    fn classes_and_controller_states_are_read() {
        let bus_off = BusErrorReport::from_frame(&error(CAN_ERR_BUSOFF, &[])).unwrap();
        assert!(bus_off.bus_off && !bus_off.error_passive);
        assert_eq!(bus_off.describe(), "bus-off");
        let passive = BusErrorReport::from_frame(&error(
            CAN_ERR_CRTL | CAN_ERR_CNT,
            &[
                0,
                CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_RX_OVERFLOW,
                0,
                0,
                0,
                0,
                12,
                130,
            ],
        ))
        .unwrap();
        assert!(passive.error_passive && passive.controller_overflow && !passive.bus_off);
        assert_eq!(passive.error_counters, Some((12, 130)));
        assert_eq!(passive.describe(), "error-passive, controller overflow");
    }

    #[test]
    fn controller_byte_counts_only_with_its_class() {
        // Byte 1 means "controller status" only when CAN_ERR_CRTL is set.
        let prot = BusErrorReport::from_frame(&error(CAN_ERR_PROT, &[0, 0xFF])).unwrap();
        assert!(prot.bus_error && !prot.error_passive && !prot.controller_overflow);
        let data =
            Frame::data(0, IfaceName::new("can0").unwrap(), CanId::Standard(1), &[]).unwrap();
        assert_eq!(BusErrorReport::from_frame(&data), None);
    }
}
