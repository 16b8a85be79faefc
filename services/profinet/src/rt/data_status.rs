//! The DataStatus byte of a cyclic frame's APDU status.

/// DataStatus: bit 0 State (primary), 1 Redundancy, 2 DataValid, 4 ProviderState (run),
/// 5 StationProblemIndicator (1 = no problem), 7 Ignore.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DataStatus(pub u8);

const PRIMARY: u8 = 0x01;
const REDUNDANCY: u8 = 0x02;
const DATA_VALID: u8 = 0x04;
const PROVIDER_RUN: u8 = 0x10;
const STATION_OK: u8 = 0x20;
const IGNORE: u8 = 0x80;

impl DataStatus {
    /// Primary, valid, running, no station problem: 0x35, what both sides send normally.
    pub const NORMAL: DataStatus = DataStatus(PRIMARY | DATA_VALID | PROVIDER_RUN | STATION_OK);

    /// The status a provider sends: primary, valid; `run` false when it stops (its data is
    /// then not to be used); `station_problem` clears the StationProblemIndicator (the
    /// device has a diagnosis).
    pub fn provider(run: bool, station_problem: bool) -> Self {
        let mut bits = PRIMARY | DATA_VALID;
        if run {
            bits |= PROVIDER_RUN;
        }
        if !station_problem {
            bits |= STATION_OK;
        }
        DataStatus(bits)
    }

    /// The primary AR sent the frame (else a backup).
    pub fn primary(self) -> bool {
        self.0 & PRIMARY != 0
    }

    /// A redundant path exists.
    pub fn redundancy(self) -> bool {
        self.0 & REDUNDANCY != 0
    }

    /// The data is valid.
    pub fn data_valid(self) -> bool {
        self.0 & DATA_VALID != 0
    }

    /// The provider runs (else it is stopped).
    pub fn provider_run(self) -> bool {
        self.0 & PROVIDER_RUN != 0
    }

    /// The station reports no problem.
    pub fn station_ok(self) -> bool {
        self.0 & STATION_OK != 0
    }

    /// The frame is to be ignored.
    pub fn ignore(self) -> bool {
        self.0 & IGNORE != 0
    }

    /// True when a consumer may take the data: valid, from a running primary provider,
    /// not marked to be ignored.
    pub fn usable(self) -> bool {
        self.data_valid() && self.provider_run() && self.primary() && !self.ignore()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rt::frame::RtFrame;
    use crate::testdata;

    #[test]
    fn the_normal_status_is_0x35_as_in_the_s7_capture() {
        assert_eq!(DataStatus::NORMAL, DataStatus(0x35));
        assert_eq!(DataStatus::provider(true, false), DataStatus::NORMAL);
        let frame = testdata::frame("rtc_cpu_8001");
        let (_, rt) = RtFrame::parse(&frame).unwrap();
        assert_eq!(rt.data_status, DataStatus::NORMAL);
        assert!(rt.data_status.usable());
        assert!(rt.data_status.station_ok());
    }

    #[test]
    fn a_problem_clears_the_indicator_and_a_stop_the_provider_state() {
        let problem = DataStatus::provider(true, true);
        assert_eq!(problem, DataStatus(0x15));
        assert!(!problem.station_ok());
        assert!(problem.usable());
        let stopped = DataStatus::provider(false, false);
        assert!(!stopped.provider_run());
        assert!(!stopped.usable());
    }

    #[test]
    fn p_net_s_backup_quirk_is_not_usable() {
        // p-net sent 0x36 (backup, redundancy) in the echo capture.
        let frame = testdata::frame("echo_dev_8000");
        let (_, rt) = RtFrame::parse(&frame).unwrap();
        assert_eq!(rt.data_status, DataStatus(0x36));
        assert!(!rt.data_status.primary());
        assert!(rt.data_status.redundancy());
        assert!(!rt.data_status.usable());
        assert!(DataStatus(0xb5).ignore());
        assert!(!DataStatus(0xb5).usable());
        assert!(!DataStatus(0x31).usable());
    }
}
