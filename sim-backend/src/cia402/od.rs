//! The simulated drive's object dictionary, as data: one table
//! ([`OBJECTS`]) gives every object's index, name, kind and sub-entries
//! (sub-index, name, data type, access, PDO mapping, default value). The
//! drive's values ([`Values`]), its SDO access checks and its EDS file
//! ([`eds`](super::eds)) are all made from this table.

/// CiA 301 data types the dictionary uses (CiA 301's data type table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataType {
    /// INTEGER8 (0x0002).
    Integer8,
    /// INTEGER16 (0x0003).
    Integer16,
    /// INTEGER32 (0x0004).
    Integer32,
    /// UNSIGNED8 (0x0005).
    Unsigned8,
    /// UNSIGNED16 (0x0006).
    Unsigned16,
    /// UNSIGNED32 (0x0007).
    Unsigned32,
    /// VISIBLE_STRING (0x0009), at most [`STRING_CAPACITY`] bytes here.
    VisibleString,
}

impl DataType {
    /// The data type's index in CiA 301's table (the EDS `DataType`).
    pub const fn code(self) -> u16 {
        match self {
            DataType::Integer8 => 0x0002,
            DataType::Integer16 => 0x0003,
            DataType::Integer32 => 0x0004,
            DataType::Unsigned8 => 0x0005,
            DataType::Unsigned16 => 0x0006,
            DataType::Unsigned32 => 0x0007,
            DataType::VisibleString => 0x0009,
        }
    }

    /// The size in bytes of a number type; `None` for a string (its
    /// length is the value's).
    pub const fn size(self) -> Option<usize> {
        match self {
            DataType::Integer8 | DataType::Unsigned8 => Some(1),
            DataType::Integer16 | DataType::Unsigned16 => Some(2),
            DataType::Integer32 | DataType::Unsigned32 => Some(4),
            DataType::VisibleString => None,
        }
    }

    /// Whether values are two's complement signed.
    pub const fn signed(self) -> bool {
        matches!(
            self,
            DataType::Integer8 | DataType::Integer16 | DataType::Integer32
        )
    }
}

/// Access over SDO (the EDS `AccessType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Read only; the drive changes the value (`ro`).
    Ro,
    /// Write only (`wo`).
    Wo,
    /// Read and write (`rw`).
    Rw,
    /// Read only, never changes (`const`).
    Const,
}

impl Access {
    /// The EDS spelling.
    pub const fn eds(self) -> &'static str {
        match self {
            Access::Ro => "ro",
            Access::Wo => "wo",
            Access::Rw => "rw",
            Access::Const => "const",
        }
    }

    /// Whether an SDO upload may read it.
    pub const fn readable(self) -> bool {
        !matches!(self, Access::Wo)
    }

    /// Whether an SDO download may write it.
    pub const fn writable(self) -> bool {
        matches!(self, Access::Wo | Access::Rw)
    }
}

/// An entry's default (power-on) value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DefaultValue {
    /// A number (of the entry's type).
    Int(i64),
    /// A number plus the node id (COB-IDs, serial number): `$NODEID+base`
    /// in the EDS.
    NodeId(u32),
    /// A string.
    Str(&'static str),
}

/// The kind of an object (the EDS `ObjectType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// VAR (0x7): one value at sub-index 0.
    Var,
    /// ARRAY (0x8): sub 0 is the count, the others one type.
    Array,
    /// RECORD (0x9): sub 0 is the count, the others of any type.
    Record,
}

impl Kind {
    /// The EDS `ObjectType` code.
    pub const fn code(self) -> u8 {
        match self {
            Kind::Var => 0x7,
            Kind::Array => 0x8,
            Kind::Record => 0x9,
        }
    }
}

/// One sub-entry (for a VAR, the object itself at sub-index 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// Sub-index.
    pub sub: u8,
    /// Parameter name.
    pub name: &'static str,
    /// Data type.
    pub ty: DataType,
    /// SDO access.
    pub access: Access,
    /// Whether a PDO may map it.
    pub pdo: bool,
    /// Power-on value.
    pub default: DefaultValue,
}

/// One object of the dictionary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ObjectDef {
    /// Index.
    pub index: u16,
    /// Parameter name.
    pub name: &'static str,
    /// VAR, ARRAY or RECORD.
    pub kind: Kind,
    /// Sub-entries in sub-index order (sub 0 first).
    pub entries: &'static [Entry],
}

/// Capacity of a VISIBLE_STRING value (bytes).
pub const STRING_CAPACITY: usize = 32;

/// The device name 0x1008 (longer than 4 bytes: read by segmented upload).
pub const DEVICE_NAME: &str = "anguilla simulated CiA 402 axis";
/// Device type 0x1000: CiA 402 drive (0x0192), servo drive (0x0002).
pub const DEVICE_TYPE: u32 = 0x0002_0192;
/// Vendor id 0x1018:01 (0: no CiA-assigned vendor; a simulation).
pub const VENDOR_ID: u32 = 0;
/// Product code 0x1018:02.
pub const PRODUCT_CODE: u32 = 0x0402_0001;
/// Revision number 0x1018:03.
pub const REVISION: u32 = 0x0001_0000;
/// Rated torque 0x6076 (mN·m), the unit of the torque objects.
pub const RATED_TORQUE_MNM: u32 = 500;
/// Position encoder increments per motor revolution (0x608F:01).
pub const INCREMENTS_PER_TURN: u32 = 65536;

macro_rules! e {
    ($sub:literal, $name:literal, $ty:ident, $acc:ident, $pdo:literal, $def:expr) => {
        Entry {
            sub: $sub,
            name: $name,
            ty: DataType::$ty,
            access: Access::$acc,
            pdo: $pdo,
            default: $def,
        }
    };
}

macro_rules! var {
    ($index:literal, $name:literal, $ty:ident, $acc:ident, $pdo:literal, $def:expr) => {
        ObjectDef {
            index: $index,
            name: $name,
            kind: Kind::Var,
            entries: &[e!(0, $name, $ty, $acc, $pdo, $def)],
        }
    };
}

const fn count(n: i64) -> Entry {
    Entry {
        sub: 0,
        name: "Highest sub-index supported",
        ty: DataType::Unsigned8,
        access: Access::Const,
        pdo: false,
        default: DefaultValue::Int(n),
    }
}

macro_rules! pdo_comm {
    ($index:literal, $name:literal, $cob:expr) => {
        ObjectDef {
            index: $index,
            name: $name,
            kind: Kind::Record,
            entries: &[
                count(2),
                e!(
                    1,
                    "COB-ID",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::NodeId($cob)
                ),
                e!(
                    2,
                    "Transmission type",
                    Unsigned8,
                    Rw,
                    false,
                    DefaultValue::Int(1)
                ),
            ],
        }
    };
}

macro_rules! pdo_map {
    ($index:literal, $name:literal, $n:literal, [$m1:literal, $m2:literal]) => {
        ObjectDef {
            index: $index,
            name: $name,
            kind: Kind::Record,
            entries: &[
                e!(
                    0,
                    "Number of mapped objects",
                    Unsigned8,
                    Rw,
                    false,
                    DefaultValue::Int($n)
                ),
                e!(
                    1,
                    "Mapping entry 1",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::Int($m1)
                ),
                e!(
                    2,
                    "Mapping entry 2",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::Int($m2)
                ),
                e!(
                    3,
                    "Mapping entry 3",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::Int(0)
                ),
                e!(
                    4,
                    "Mapping entry 4",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::Int(0)
                ),
                e!(
                    5,
                    "Mapping entry 5",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::Int(0)
                ),
                e!(
                    6,
                    "Mapping entry 6",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::Int(0)
                ),
                e!(
                    7,
                    "Mapping entry 7",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::Int(0)
                ),
                e!(
                    8,
                    "Mapping entry 8",
                    Unsigned32,
                    Rw,
                    false,
                    DefaultValue::Int(0)
                ),
            ],
        }
    };
}

/// The dictionary, in index order. Defaults: RPDO1 (0x200 + n, SYNC)
/// maps controlword and target position, TPDO1 (0x180 + n, every SYNC)
/// statusword and position actual; PDOs 2 exist disabled and unmapped.
pub const OBJECTS: &[ObjectDef] = &[
    var!(
        0x1000,
        "Device type",
        Unsigned32,
        Ro,
        false,
        DefaultValue::Int(DEVICE_TYPE as i64)
    ),
    var!(
        0x1001,
        "Error register",
        Unsigned8,
        Ro,
        true,
        DefaultValue::Int(0)
    ),
    var!(
        0x1006,
        "Communication cycle period",
        Unsigned32,
        Rw,
        false,
        DefaultValue::Int(0)
    ),
    var!(
        0x1008,
        "Manufacturer device name",
        VisibleString,
        Const,
        false,
        DefaultValue::Str(DEVICE_NAME)
    ),
    ObjectDef {
        index: 0x1016,
        name: "Consumer heartbeat time",
        kind: Kind::Array,
        entries: &[
            count(1),
            e!(
                1,
                "Consumer heartbeat time 1",
                Unsigned32,
                Rw,
                false,
                DefaultValue::Int(0)
            ),
        ],
    },
    var!(
        0x1017,
        "Producer heartbeat time",
        Unsigned16,
        Rw,
        false,
        DefaultValue::Int(0)
    ),
    ObjectDef {
        index: 0x1018,
        name: "Identity object",
        kind: Kind::Record,
        entries: &[
            count(4),
            e!(
                1,
                "Vendor-ID",
                Unsigned32,
                Ro,
                false,
                DefaultValue::Int(VENDOR_ID as i64)
            ),
            e!(
                2,
                "Product code",
                Unsigned32,
                Ro,
                false,
                DefaultValue::Int(PRODUCT_CODE as i64)
            ),
            e!(
                3,
                "Revision number",
                Unsigned32,
                Ro,
                false,
                DefaultValue::Int(REVISION as i64)
            ),
            e!(
                4,
                "Serial number",
                Unsigned32,
                Ro,
                false,
                DefaultValue::NodeId(0)
            ),
        ],
    },
    pdo_comm!(0x1400, "RPDO1 communication parameter", 0x200),
    pdo_comm!(0x1401, "RPDO2 communication parameter", 0x8000_0300),
    pdo_map!(
        0x1600,
        "RPDO1 mapping parameter",
        2,
        [0x6040_0010, 0x607A_0020]
    ),
    pdo_map!(0x1601, "RPDO2 mapping parameter", 0, [0, 0]),
    pdo_comm!(0x1800, "TPDO1 communication parameter", 0x180),
    pdo_comm!(0x1801, "TPDO2 communication parameter", 0x8000_0280),
    pdo_map!(
        0x1A00,
        "TPDO1 mapping parameter",
        2,
        [0x6041_0010, 0x6064_0020]
    ),
    pdo_map!(0x1A01, "TPDO2 mapping parameter", 0, [0, 0]),
    var!(
        0x2000,
        "Axis label",
        VisibleString,
        Rw,
        false,
        DefaultValue::Str("unnamed axis")
    ),
    var!(
        0x2001,
        "Simulated fault",
        Unsigned16,
        Wo,
        false,
        DefaultValue::Int(0)
    ),
    var!(
        0x6040,
        "Controlword",
        Unsigned16,
        Rw,
        true,
        DefaultValue::Int(0)
    ),
    var!(
        0x6041,
        "Statusword",
        Unsigned16,
        Ro,
        true,
        DefaultValue::Int(0)
    ),
    var!(
        0x605A,
        "Quick stop option code",
        Integer16,
        Rw,
        false,
        DefaultValue::Int(2)
    ),
    var!(
        0x6060,
        "Modes of operation",
        Integer8,
        Rw,
        false,
        DefaultValue::Int(0)
    ),
    var!(
        0x6061,
        "Modes of operation display",
        Integer8,
        Ro,
        true,
        DefaultValue::Int(0)
    ),
    var!(
        0x6064,
        "Position actual value",
        Integer32,
        Ro,
        true,
        DefaultValue::Int(0)
    ),
    var!(
        0x606C,
        "Velocity actual value",
        Integer32,
        Ro,
        true,
        DefaultValue::Int(0)
    ),
    var!(
        0x6076,
        "Motor rated torque",
        Unsigned32,
        Ro,
        false,
        DefaultValue::Int(RATED_TORQUE_MNM as i64)
    ),
    var!(
        0x6077,
        "Torque actual value",
        Integer16,
        Ro,
        true,
        DefaultValue::Int(0)
    ),
    var!(
        0x607A,
        "Target position",
        Integer32,
        Rw,
        true,
        DefaultValue::Int(0)
    ),
    ObjectDef {
        index: 0x608F,
        name: "Position encoder resolution",
        kind: Kind::Array,
        entries: &[
            count(2),
            e!(
                1,
                "Encoder increments",
                Unsigned32,
                Ro,
                false,
                DefaultValue::Int(INCREMENTS_PER_TURN as i64)
            ),
            e!(
                2,
                "Motor revolutions",
                Unsigned32,
                Ro,
                false,
                DefaultValue::Int(1)
            ),
        ],
    },
    var!(
        0x60B1,
        "Velocity offset",
        Integer32,
        Rw,
        true,
        DefaultValue::Int(0)
    ),
    var!(
        0x60B2,
        "Torque offset",
        Integer16,
        Rw,
        true,
        DefaultValue::Int(0)
    ),
    ObjectDef {
        index: 0x60C2,
        name: "Interpolation time period",
        kind: Kind::Record,
        entries: &[
            count(2),
            e!(
                1,
                "Interpolation time period value",
                Unsigned8,
                Rw,
                false,
                DefaultValue::Int(1)
            ),
            e!(
                2,
                "Interpolation time index",
                Integer8,
                Rw,
                false,
                DefaultValue::Int(-3)
            ),
        ],
    },
    var!(
        0x6502,
        "Supported drive modes",
        Unsigned32,
        Ro,
        false,
        DefaultValue::Int(1 << 7)
    ),
];

const fn count_slots() -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < OBJECTS.len() {
        n += OBJECTS[i].entries.len();
        i += 1;
    }
    n
}

/// Number of sub-entries in the dictionary (the values a drive holds).
pub const SLOTS: usize = count_slots();

/// The position of `index:sub` among all sub-entries, in table order, or
/// an error naming what does not exist.
pub const fn find(index: u16, sub: u8) -> Result<usize, LookupError> {
    let mut slot = 0;
    let mut i = 0;
    while i < OBJECTS.len() {
        let o = &OBJECTS[i];
        if o.index == index {
            let mut j = 0;
            while j < o.entries.len() {
                if o.entries[j].sub == sub {
                    return Ok(slot + j);
                }
                j += 1;
            }
            return Err(LookupError::NoSubIndex);
        }
        slot += o.entries.len();
        i += 1;
    }
    Err(LookupError::NoObject)
}

/// The slot of an entry that the table is known to hold (a compile-time
/// constant: a missing entry fails the build).
pub const fn slot(index: u16, sub: u8) -> usize {
    match find(index, sub) {
        Ok(s) => s,
        Err(_) => panic!("entry missing from the object dictionary table"),
    }
}

/// Why a lookup failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LookupError {
    /// No object at the index.
    NoObject,
    /// The object has no such sub-index.
    NoSubIndex,
}

const fn build_flat() -> [(u16, &'static Entry); SLOTS] {
    let mut out: [(u16, &'static Entry); SLOTS] = [(0, &OBJECTS[0].entries[0]); SLOTS];
    let mut k = 0;
    let mut i = 0;
    while i < OBJECTS.len() {
        let mut j = 0;
        while j < OBJECTS[i].entries.len() {
            out[k] = (OBJECTS[i].index, &OBJECTS[i].entries[j]);
            k += 1;
            j += 1;
        }
        i += 1;
    }
    out
}

/// Every sub-entry with its object's index, in table order (slot order).
pub const FLAT: [(u16, &Entry); SLOTS] = build_flat();

/// One value: the little-endian bytes of a number (its type's size) or
/// a string's bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Value {
    len: u8,
    bytes: [u8; STRING_CAPACITY],
}

impl Value {
    /// The value's bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes[..self.len as usize]
    }

    /// A value holding `data` (cut to [`STRING_CAPACITY`]).
    pub fn from_bytes(data: &[u8]) -> Self {
        let n = data.len().min(STRING_CAPACITY);
        let mut bytes = [0; STRING_CAPACITY];
        bytes[..n].copy_from_slice(&data[..n]);
        Value {
            len: n as u8,
            bytes,
        }
    }

    /// A number of type `ty` (truncated to its size).
    pub fn number(ty: DataType, v: i64) -> Self {
        let n = ty.size().unwrap_or(4);
        Self::from_bytes(&v.to_le_bytes()[..n])
    }

    /// The value as a number: sign-extended for a signed type,
    /// zero-extended otherwise (0 for a string).
    pub fn as_i64(&self, ty: DataType) -> i64 {
        let mut b = [0u8; 8];
        let n = (self.len as usize).min(8);
        b[..n].copy_from_slice(&self.bytes[..n]);
        if ty.signed() && n > 0 && n < 8 && b[n - 1] & 0x80 != 0 {
            for x in &mut b[n..] {
                *x = 0xFF;
            }
        }
        i64::from_le_bytes(b)
    }
}

/// The values of one drive's dictionary.
#[derive(Debug, Clone)]
pub struct Values {
    node: u8,
    v: [Value; SLOTS],
}

impl Values {
    /// Power-on values for node `node`.
    pub fn new(node: u8) -> Self {
        let mut v = Values {
            node,
            v: [Value::from_bytes(&[]); SLOTS],
        };
        v.reset(|_| true);
        v
    }

    /// The power-on value of slot `slot`.
    pub fn default_of(&self, slot: usize) -> Value {
        let e = FLAT[slot].1;
        match e.default {
            DefaultValue::Int(n) => Value::number(e.ty, n),
            DefaultValue::NodeId(base) => {
                Value::number(e.ty, i64::from(base.wrapping_add(u32::from(self.node))))
            }
            DefaultValue::Str(s) => Value::from_bytes(s.as_bytes()),
        }
    }

    /// Back to the power-on values every entry whose index `which` selects.
    pub fn reset(&mut self, which: impl Fn(u16) -> bool) {
        for (slot, (index, _)) in FLAT.iter().enumerate() {
            if which(*index) {
                self.v[slot] = self.default_of(slot);
            }
        }
    }

    /// The value in `slot`.
    pub fn get(&self, slot: usize) -> &Value {
        &self.v[slot]
    }

    /// The value in `slot` as a number.
    pub fn num(&self, slot: usize) -> i64 {
        self.v[slot].as_i64(FLAT[slot].1.ty)
    }

    /// Sets `slot` to the bytes `data` (no checks: the caller checked).
    pub fn set_bytes(&mut self, slot: usize, data: &[u8]) {
        self.v[slot] = Value::from_bytes(data);
    }

    /// Sets a number slot (truncated to its type).
    pub fn set_num(&mut self, slot: usize, v: i64) {
        self.v[slot] = Value::number(FLAT[slot].1.ty, v);
    }
}
