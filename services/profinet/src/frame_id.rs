//! FrameID: the first two bytes after the EtherType, which select the PROFINET protocol.
//!
//! Tools name the cyclic ranges inconsistently, so the device keys on the IOCR's RTClass
//! together with the range: an S7-1500 connects with RTClass 2 and FrameIDs 0x8000..,
//! legacy controllers (profinet-py) with RTClass 1 and 0xC000.., leaving the output CR's
//! FrameID at 0xFFFF for the device to choose.

use std::ops::RangeInclusive;

/// The RT class an IOCR asks for in its IOCRProperties.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RtClass {
    /// RT_CLASS_1 (legacy): unicast FrameIDs 0xC000..=0xF7FF.
    One,
    /// RT_CLASS_2 without synchronisation, as S7-1500s use it: unicast 0x8000..=0xBBFF.
    Two,
}

/// Output-CR FrameID with which the controller lets the device choose.
pub const DEVICE_CHOOSES: u16 = 0xffff;

impl RtClass {
    /// The unicast FrameIDs of this class.
    pub fn unicast_frame_ids(self) -> RangeInclusive<u16> {
        match self {
            RtClass::One => 0xc000..=0xf7ff,
            RtClass::Two => 0x8000..=0xbbff,
        }
    }

    /// True when `frame_id` is a unicast FrameID of this class.
    pub fn accepts(self, frame_id: u16) -> bool {
        self.unicast_frame_ids().contains(&frame_id)
    }
}

/// What a FrameID is used for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameUse {
    /// Time synchronisation (PTCP RTSync).
    TimeSync,
    /// Isochronous RT_CLASS_3 data.
    RtClass3,
    /// Cyclic data of an RT class, unicast or multicast.
    Cyclic {
        /// The RT class whose range holds the FrameID.
        class: RtClass,
        /// True for the multicast part of the range.
        multicast: bool,
    },
    /// High-priority alarm (RTA).
    AlarmHigh,
    /// Low-priority alarm (RTA).
    AlarmLow,
    /// DCP Hello.
    DcpHello,
    /// DCP Get and Set, requests and responses.
    DcpGetSet,
    /// DCP Identify request (multicast).
    DcpIdentifyRequest,
    /// DCP Identify response (unicast).
    DcpIdentifyResponse,
    /// PTCP announce, follow-up and delay measurement.
    Ptcp,
    /// Fragmented frames.
    Fragmentation,
    /// Not assigned.
    Reserved,
}

/// FrameID of a DCP Hello.
pub const DCP_HELLO: u16 = 0xfefc;
/// FrameID of DCP Get/Set requests and responses.
pub const DCP_GET_SET: u16 = 0xfefd;
/// FrameID of a DCP Identify request.
pub const DCP_IDENTIFY_REQUEST: u16 = 0xfefe;
/// FrameID of a DCP Identify response.
pub const DCP_IDENTIFY_RESPONSE: u16 = 0xfeff;
/// FrameID of high-priority alarms.
pub const ALARM_HIGH: u16 = 0xfc01;
/// FrameID of low-priority alarms.
pub const ALARM_LOW: u16 = 0xfe01;

/// Classifies a FrameID.
pub fn frame_use(frame_id: u16) -> FrameUse {
    let cyclic = |class, multicast| FrameUse::Cyclic { class, multicast };
    match frame_id {
        0x0000..=0x00ff => FrameUse::TimeSync,
        0x0100..=0x7fff => FrameUse::RtClass3,
        0x8000..=0xbbff => cyclic(RtClass::Two, false),
        0xbc00..=0xbfff => cyclic(RtClass::Two, true),
        0xc000..=0xf7ff => cyclic(RtClass::One, false),
        0xf800..=0xfbff => cyclic(RtClass::One, true),
        ALARM_HIGH => FrameUse::AlarmHigh,
        ALARM_LOW => FrameUse::AlarmLow,
        DCP_HELLO => FrameUse::DcpHello,
        DCP_GET_SET => FrameUse::DcpGetSet,
        DCP_IDENTIFY_REQUEST => FrameUse::DcpIdentifyRequest,
        DCP_IDENTIFY_RESPONSE => FrameUse::DcpIdentifyResponse,
        0xff00..=0xff43 => FrameUse::Ptcp,
        0xff80..=0xff8f => FrameUse::Fragmentation,
        _ => FrameUse::Reserved,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_s7_frame_ids_are_rt_class_2_and_profinet_py_s_are_rt_class_1() {
        assert_eq!(
            frame_use(0x8000),
            FrameUse::Cyclic {
                class: RtClass::Two,
                multicast: false
            }
        );
        assert_eq!(
            frame_use(0x8001),
            FrameUse::Cyclic {
                class: RtClass::Two,
                multicast: false
            }
        );
        assert_eq!(
            frame_use(0xc001),
            FrameUse::Cyclic {
                class: RtClass::One,
                multicast: false
            }
        );
        assert!(RtClass::Two.accepts(0x8001));
        assert!(!RtClass::Two.accepts(0xc001));
        assert!(RtClass::One.accepts(0xc001));
        assert!(!RtClass::One.accepts(DEVICE_CHOOSES));
    }

    #[test]
    fn range_edges_are_classified() {
        assert_eq!(frame_use(0x00ff), FrameUse::TimeSync);
        assert_eq!(frame_use(0x0100), FrameUse::RtClass3);
        assert_eq!(
            frame_use(0xbc00),
            FrameUse::Cyclic {
                class: RtClass::Two,
                multicast: true
            }
        );
        assert_eq!(
            frame_use(0xf7ff),
            FrameUse::Cyclic {
                class: RtClass::One,
                multicast: false
            }
        );
        assert_eq!(
            frame_use(0xfbff),
            FrameUse::Cyclic {
                class: RtClass::One,
                multicast: true
            }
        );
        assert_eq!(frame_use(0xfc00), FrameUse::Reserved);
        assert_eq!(frame_use(ALARM_HIGH), FrameUse::AlarmHigh);
        assert_eq!(frame_use(ALARM_LOW), FrameUse::AlarmLow);
        assert_eq!(frame_use(DCP_HELLO), FrameUse::DcpHello);
        assert_eq!(frame_use(DCP_GET_SET), FrameUse::DcpGetSet);
        assert_eq!(
            frame_use(DCP_IDENTIFY_REQUEST),
            FrameUse::DcpIdentifyRequest
        );
        assert_eq!(
            frame_use(DCP_IDENTIFY_RESPONSE),
            FrameUse::DcpIdentifyResponse
        );
        assert_eq!(frame_use(0xff43), FrameUse::Ptcp);
        assert_eq!(frame_use(0xff80), FrameUse::Fragmentation);
        assert_eq!(frame_use(0xffff), FrameUse::Reserved);
    }
}
