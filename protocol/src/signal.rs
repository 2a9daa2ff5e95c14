//! Signal descriptors: where a value sits in a frame and how it is scaled.
//!
//! Every field of every message is described once here, as a [`Signal`]: its
//! start bit and length (Intel / little-endian bit numbering, as a DBC file's
//! `@1` signals: bit `b` of byte `k` is bit `8k + b`), whether the raw integer
//! is two's complement, its factor and offset (`physical = raw × factor +
//! offset`) and its documented range. The codec in [`crate::message`] places
//! and reads bits only through these descriptors, and [`crate::dbc`] writes
//! the DBC file from the same descriptors, so the two cannot drift.

/// How a signal takes part in DBC multiplexing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mux {
    /// Always present.
    None,
    /// The multiplexor switch (`M` in a DBC file).
    Switch,
    /// Present only when the switch holds this value (`m<value>`).
    When(u8),
}

/// One field of a message: position, encoding, scaling, range and meaning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Signal {
    /// Signal name (unique within its message; slot signals get a prefix).
    pub name: &'static str,
    /// For repeated per-node slots (FD setpoint groups): the slot index.
    pub slot: Option<u8>,
    /// Least significant bit, Intel numbering (bit `b` of byte `k` = `8k + b`).
    pub start: u16,
    /// Number of bits (1..=32).
    pub len: u8,
    /// Raw value is two's complement.
    pub signed: bool,
    /// Physical units per raw count.
    pub factor: f64,
    /// Physical value of raw 0.
    pub offset: f64,
    /// Smallest valid physical value (documented range).
    pub min: f64,
    /// Largest valid physical value (documented range).
    pub max: f64,
    /// SI unit (empty for counters, enums and flags).
    pub unit: &'static str,
    /// Multiplexing role.
    pub mux: Mux,
    /// One-line meaning, copied into the DBC as a comment.
    pub comment: &'static str,
}

impl Signal {
    /// An unsigned integer field with factor 1 and range `0..=max`.
    pub const fn uint(
        name: &'static str,
        start: u16,
        len: u8,
        max: u32,
        comment: &'static str,
    ) -> Self {
        Signal {
            name,
            slot: None,
            start,
            len,
            signed: false,
            factor: 1.0,
            offset: 0.0,
            min: 0.0,
            max: max as f64,
            unit: "",
            mux: Mux::None,
            comment,
        }
    }

    /// A signed fixed-point physical quantity: `physical = raw × factor`,
    /// valid over `-limit..=limit`.
    pub const fn fixed(
        name: &'static str,
        start: u16,
        len: u8,
        factor: f64,
        limit: f64,
        unit: &'static str,
        comment: &'static str,
    ) -> Self {
        Signal {
            name,
            slot: None,
            start,
            len,
            signed: true,
            factor,
            offset: 0.0,
            min: -limit,
            max: limit,
            unit,
            mux: Mux::None,
            comment,
        }
    }

    /// An unsigned fixed-point quantity valid over `min..=max`.
    #[allow(clippy::too_many_arguments)]
    pub const fn ufixed(
        name: &'static str,
        start: u16,
        len: u8,
        factor: f64,
        min: f64,
        max: f64,
        unit: &'static str,
        comment: &'static str,
    ) -> Self {
        Signal {
            name,
            slot: None,
            start,
            len,
            signed: false,
            factor,
            offset: 0.0,
            min,
            max,
            unit,
            mux: Mux::None,
            comment,
        }
    }

    /// The same signal with a multiplexing role.
    pub const fn muxed(mut self, mux: Mux) -> Self {
        self.mux = mux;
        self
    }

    /// The same signal moved to `slot`, shifted by `slot * stride` bits.
    pub const fn in_slot(mut self, slot: u8, base: u16, stride: u16) -> Self {
        self.slot = Some(slot);
        self.start = base + self.start + slot as u16 * stride;
        self
    }

    /// Last bit (inclusive) the signal occupies.
    pub const fn end(&self) -> u16 {
        self.start + self.len as u16 - 1
    }

    /// Smallest raw value the encoding can hold.
    pub fn raw_min_repr(&self) -> i64 {
        if self.signed {
            -(1i64 << (self.len - 1))
        } else {
            0
        }
    }

    /// Largest raw value the encoding can hold.
    pub fn raw_max_repr(&self) -> i64 {
        if self.signed {
            (1i64 << (self.len - 1)) - 1
        } else {
            (1i64 << self.len) - 1
        }
    }

    /// Smallest raw value inside the documented range.
    pub fn raw_min(&self) -> i64 {
        let r = ((self.min - self.offset) / self.factor - 1e-9).ceil() as i64;
        r.max(self.raw_min_repr())
    }

    /// Largest raw value inside the documented range.
    pub fn raw_max(&self) -> i64 {
        let r = ((self.max - self.offset) / self.factor + 1e-9).floor() as i64;
        r.min(self.raw_max_repr())
    }

    /// Physical value of a raw count.
    pub fn to_physical(&self, raw: i64) -> f64 {
        raw as f64 * self.factor + self.offset
    }

    /// The raw count nearest to `value`, or `None` if `value` is not finite
    /// or lies outside the documented range (after rounding).
    pub fn to_raw(&self, value: f64) -> Option<i64> {
        if !value.is_finite() {
            return None;
        }
        let raw = ((value - self.offset) / self.factor).round();
        if raw < self.raw_min() as f64 || raw > self.raw_max() as f64 {
            return None;
        }
        Some(raw as i64)
    }

    /// Writes `raw` into `buf` (which must hold the signal's bits).
    pub fn put(&self, buf: &mut [u8], raw: i64) {
        let bits = raw as u64;
        for i in 0..self.len as usize {
            let pos = self.start as usize + i;
            let (byte, bit) = (pos / 8, pos % 8);
            if (bits >> i) & 1 == 1 {
                buf[byte] |= 1 << bit;
            } else {
                buf[byte] &= !(1 << bit);
            }
        }
    }

    /// Reads the raw value (sign-extended when signed) from `buf`.
    pub fn get(&self, buf: &[u8]) -> i64 {
        let mut bits: u64 = 0;
        for i in 0..self.len as usize {
            let pos = self.start as usize + i;
            let (byte, bit) = (pos / 8, pos % 8);
            bits |= (((buf[byte] >> bit) & 1) as u64) << i;
        }
        if self.signed && (bits >> (self.len - 1)) & 1 == 1 {
            (bits | (!0u64 << self.len)) as i64
        } else {
            bits as i64
        }
    }

    /// The DBC name: the slot prefix (`S3_`) and the name.
    pub fn dbc_name(&self) -> DbcName {
        DbcName(self.slot, self.name)
    }
}

/// Displays a signal's DBC name without allocating.
#[derive(Debug, Clone, Copy)]
pub struct DbcName(Option<u8>, &'static str);

impl core::fmt::Display for DbcName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.0 {
            Some(s) => write!(f, "S{s}_{}", self.1),
            None => write!(f, "{}", self.1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn put_get_roundtrip(start in 0u16..480, len in 1u8..=32, signed: bool, v: i64, fill: u8) {
            let s = Signal { signed, ..Signal::uint("x", start, len, 0, "") };
            let v = v.clamp(s.raw_min_repr(), s.raw_max_repr());
            let mut buf = [fill; 64];
            s.put(&mut buf, v);
            prop_assert_eq!(s.get(&buf), v);
            // Bits outside the signal are untouched.
            for pos in 0..512usize {
                if pos < start as usize || pos > s.end() as usize {
                    prop_assert_eq!((buf[pos / 8] >> (pos % 8)) & 1, (fill >> (pos % 8)) & 1);
                }
            }
        }
    }

    #[test]
    fn intel_bit_numbering_matches_dbc() {
        // A 12-bit signal at start bit 4: low nibble of it in byte 0's high
        // nibble, the rest in byte 1 (as cantools places `4|12@1+`).
        let s = Signal::uint("x", 4, 12, 4095, "");
        let mut buf = [0u8; 2];
        s.put(&mut buf, 0xABC);
        assert_eq!(buf, [0xC0, 0xAB]);
        let n = Signal::fixed("y", 0, 8, 1.0, 100.0, "", "");
        let mut b = [0u8; 1];
        n.put(&mut b, -2);
        assert_eq!(b, [0xFE]);
        assert_eq!(n.get(&b), -2);
    }

    #[test]
    fn range_is_enforced() {
        let s = Signal::fixed("p", 0, 14, 0.0002, 1.5, "rad", "");
        assert_eq!(s.raw_max(), 7500);
        assert_eq!(s.raw_min(), -7500);
        assert_eq!(s.to_raw(1.5), Some(7500));
        assert_eq!(s.to_raw(1.5002), None);
        assert_eq!(s.to_raw(f64::NAN), None);
        assert_eq!(s.to_raw(-1.4999), Some(-7500));
    }
}
