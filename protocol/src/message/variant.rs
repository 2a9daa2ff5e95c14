//! Which bus the protocol runs on: classic CAN or CAN FD.

/// Which bus the protocol runs on; layouts and frame kinds differ.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variant {
    /// Classic CAN 2.0A, 8-byte frames.
    Classic,
    /// CAN FD with bit-rate switching, frames up to 64 bytes.
    Fd,
}

impl Variant {
    /// Bits of the SYNC counter a setpoint carries as its cycle tag.
    pub const fn cycle_tag_bits(self) -> u8 {
        match self {
            Variant::Classic => 4,
            Variant::Fd => 8,
        }
    }

    /// The cycle tag of the setpoints to apply at SYNC `counter`.
    pub const fn cycle_tag(self, counter: u16) -> u8 {
        (counter & ((1 << self.cycle_tag_bits()) - 1)) as u8
    }
}

impl core::fmt::Display for Variant {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Variant::Classic => "classic CAN",
            Variant::Fd => "CAN FD",
        })
    }
}
