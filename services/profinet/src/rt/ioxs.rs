//! IOPS and IOCS: the provider and consumer status byte of one submodule's data.

/// An IOxS byte: bit 7 DataState (1 = good), bits 6..5 Instance, bit 0 Extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ioxs(pub u8);

impl Ioxs {
    /// Good, detected by the subslot, no extension.
    pub const GOOD: Ioxs = Ioxs(0x80);
    /// Bad, detected by the subslot.
    pub const BAD: Ioxs = Ioxs(0x00);

    /// True when the data (or its consumption) is good. Only bit 7 counts: controllers set
    /// the instance and extension bits differently.
    pub fn is_good(self) -> bool {
        self.0 & 0x80 != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_data_state_bit_decides() {
        assert!(Ioxs::GOOD.is_good());
        assert!(Ioxs(0xe1).is_good());
        assert!(!Ioxs::BAD.is_good());
        assert!(!Ioxs(0x60).is_good());
    }
}
