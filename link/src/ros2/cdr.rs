//! OMG CDR (XCDR1), little-endian, as ROS 2's middlewares put it on the
//! wire: a 4-byte encapsulation header (`00 01 00 00`, CDR_LE), then each
//! primitive aligned to its own size (at most 8) counted from the end of
//! the header; a string is its length with the NUL (u32), its bytes and
//! the NUL; a sequence is its element count (u32) and its elements; a
//! fixed array its elements alone.

/// The encapsulation header of little-endian plain CDR.
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// A CDR message being written.
#[derive(Debug, Clone)]
pub struct Writer {
    buf: Vec<u8>,
}

impl Default for Writer {
    fn default() -> Self {
        Self::new()
    }
}

impl Writer {
    /// An empty message (the header only).
    pub fn new() -> Self {
        let mut buf = Vec::with_capacity(256);
        buf.extend_from_slice(&CDR_LE);
        Self { buf }
    }

    fn align(&mut self, n: usize) {
        let off = self.buf.len() - CDR_LE.len();
        let pad = (n - off % n) % n;
        self.buf.resize(self.buf.len() + pad, 0);
    }

    /// A `uint8`, `byte`, `char` or `bool`.
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.buf.push(v);
        self
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A `string` (UTF-8; an interior NUL would end it early for a C
    /// reader, so none is written: each becomes U+FFFD).
    pub fn string(&mut self, s: &str) -> &mut Self {
        let s = s.replace('\0', "\u{FFFD}");
        self.len(s.len() + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        self
    }

    /// A sequence's element count.
    pub fn len(&mut self, n: usize) -> &mut Self {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX))
    }

    /// A `float64[]` (count and elements).
    pub fn f64_seq(&mut self, v: &[f64]) -> &mut Self {
        self.len(v.len());
        for &x in v {
            self.f64(x);
        }
        self
    }

    /// The bytes, header included.
    pub fn finish(self) -> Vec<u8> {
        self.buf
    }
}

/// What was wrong with a CDR message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CdrError {
    /// The header is not little-endian plain CDR (`00 01 00 00`; big-endian
    /// `00 00` is not read).
    Header([u8; 2]),
    /// The message ends before `what`.
    Short {
        /// The field being read.
        what: &'static str,
    },
    /// A string is not NUL-terminated UTF-8.
    BadString,
}

impl std::fmt::Display for CdrError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Header(h) => write!(
                f,
                "CDR encapsulation {:02x} {:02x}: expected 00 01 (plain CDR, little-endian)",
                h[0], h[1]
            ),
            Self::Short { what } => write!(f, "the CDR message ends before its {what}"),
            Self::BadString => write!(f, "a CDR string is not NUL-terminated UTF-8"),
        }
    }
}

impl std::error::Error for CdrError {}

/// A CDR message being read; every read is bounded by the message.
#[derive(Debug)]
pub struct Reader<'a> {
    body: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// Checks the header.
    pub fn new(msg: &'a [u8]) -> Result<Self, CdrError> {
        match msg {
            [0x00, 0x01, _, _, body @ ..] => Ok(Self { body, at: 0 }),
            [a, b, _, _, ..] => Err(CdrError::Header([*a, *b])),
            _ => Err(CdrError::Short {
                what: "encapsulation header",
            }),
        }
    }

    fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], CdrError> {
        let at = self.at.next_multiple_of(n.clamp(1, 8));
        let end = at.checked_add(n).ok_or(CdrError::Short { what })?;
        let b = self.body.get(at..end).ok_or(CdrError::Short { what })?;
        self.at = end;
        Ok(b)
    }

    /// A `uint8`.
    pub fn u8(&mut self, what: &'static str) -> Result<u8, CdrError> {
        Ok(self.take(1, what)?[0])
    }

    /// A `uint32`.
    pub fn u32(&mut self, what: &'static str) -> Result<u32, CdrError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// An `int32`.
    pub fn i32(&mut self, what: &'static str) -> Result<i32, CdrError> {
        Ok(self.u32(what)? as i32)
    }

    /// A `float64`.
    pub fn f64(&mut self, what: &'static str) -> Result<f64, CdrError> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(f64::from_le_bytes(a))
    }

    /// A `string`.
    pub fn string(&mut self, what: &'static str) -> Result<String, CdrError> {
        let n = self.u32(what)? as usize;
        if n == 0 {
            return Ok(String::new());
        }
        let end = self.at.checked_add(n).ok_or(CdrError::Short { what })?;
        let b = self
            .body
            .get(self.at..end)
            .ok_or(CdrError::Short { what })?;
        self.at = end;
        match b.split_last() {
            Some((0, s)) => std::str::from_utf8(s)
                .map(str::to_string)
                .map_err(|_| CdrError::BadString),
            _ => Err(CdrError::BadString),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_align_after_the_header_and_read_back() {
        let mut w = Writer::new();
        w.u8(7).f64(1.5).string("ab").u32(3).i32(-2);
        let b = w.finish();
        // header, u8, 7 bytes of padding, f64, u32 3 + "ab\0", 1 byte of
        // padding, u32, i32
        assert_eq!(&b[..5], &[0, 1, 0, 0, 7]);
        assert_eq!(&b[12..20], &1.5f64.to_le_bytes());
        assert_eq!(&b[20..27], &[3, 0, 0, 0, b'a', b'b', 0]);
        assert_eq!(b.len(), 4 + 8 + 8 + 7 + 1 + 4 + 4);
        let mut r = Reader::new(&b).unwrap();
        assert_eq!(r.u8("a").unwrap(), 7);
        assert_eq!(r.f64("b").unwrap(), 1.5);
        assert_eq!(r.string("c").unwrap(), "ab");
        assert_eq!(r.u32("d").unwrap(), 3);
        assert_eq!(r.i32("e").unwrap(), -2);
        assert_eq!(r.u8("f"), Err(CdrError::Short { what: "f" }));
    }

    #[test]
    fn hostile_messages_are_errors_not_panics() {
        assert!(matches!(
            Reader::new(&[0, 0, 0, 0]),
            Err(CdrError::Header(_))
        ));
        assert!(Reader::new(&[0, 1]).is_err());
        // a string claiming 4 GiB
        let mut r = Reader::new(&[0, 1, 0, 0, 0xff, 0xff, 0xff, 0xff, b'a']).unwrap();
        assert!(r.string("s").is_err());
        // a string without its NUL
        let mut r = Reader::new(&[0, 1, 0, 0, 2, 0, 0, 0, b'a', b'b']).unwrap();
        assert_eq!(r.string("s"), Err(CdrError::BadString));
        for n in 0..64 {
            let junk: Vec<u8> = (0..n).map(|i| (i * 37 + 1) as u8).collect();
            let mut b = CDR_LE.to_vec();
            b.extend(junk);
            let mut r = Reader::new(&b).unwrap();
            let _ = r.string("s");
            let _ = r.f64("f");
        }
    }
}
