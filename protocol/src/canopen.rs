//! CANopen (CiA 301 application layer, CiA 402 drive profile): the wire
//! codec subset a master needs to drive bought CiA 402 servo drives (e.g.
//! Maxon EPOS4), beside anguilla's own [`crate::message`].
//!
//! Sources: CiA 301 v4.2 (CANopen application layer and communication
//! profile): its "pre-defined connection set" for the COB-IDs, its SDO
//! initiate download / upload and abort protocols for the SDO command byte
//! (client command specifier `ccs`, server `scs`, `n`, `e`, `s` bits), its
//! SDO abort-code table, its EMCY write protocol and emergency error-code
//! table, its NMT node-control and heartbeat protocols; CiA 402-2 (drives
//! and motion control, the "power drive system" finite state machine) for
//! the statusword and controlword bit patterns and the object indices.
//! This module only encodes and decodes; it keeps no state (a node's SDO
//! transaction or state machine stepping belongs to the caller).
//!
//! | COB-ID          | message                  | dir             | bytes | layout (byte offsets, little-endian)                  |
//! |-----------------|--------------------------|-----------------|-------|-------------------------------------------------------|
//! | 0x000           | NMT                      | master → nodes  | 2     | 0 command, 1 node (0 = all)                           |
//! | 0x080           | SYNC                     | master → nodes  | 0..=1 | optional counter                                      |
//! | 0x080 + n       | EMCY                     | node → all      | 8     | 0 error code u16, 2 error register u8, 3..8 vendor    |
//! | 0x180..0x480 + n| TPDO1..4                 | node → master   | 0..=8 | as mapped (raw here)                                  |
//! | 0x200..0x500 + n| RPDO1..4                 | master → node   | 0..=8 | as mapped (raw here)                                  |
//! | 0x580 + n       | SDO server → client      | node → master   | 8     | 0 command, 1 index u16, 3 subindex, 4 data/abort u32  |
//! | 0x600 + n       | SDO client → server      | master → node   | 8     | same                                                  |
//! | 0x700 + n       | heartbeat / boot-up      | node → all      | 1     | 0 NMT state                                           |
//!
//! Node ids are 1..=127. Only classic 11-bit data frames are decoded: remote
//! frames (node guarding), the TIME object (0x100) and LSS (0x7E4/0x7E5)
//! are outside this subset and are decode errors, as are SDO block
//! transfers. SDO transfers are expedited (1..=4 bytes in the initiate
//! message) or segmented (initiate, then 7-byte segments with an
//! alternating toggle bit: [`SdoRequest::DownloadSegment`],
//! [`SdoRequest::UploadSegment`] and their responses).
//! PDO payloads are kept raw: what they mean depends on the node's mapping.
//! Encoding cannot fail — every field is range-checked when its value is
//! built ([`NodeId::new`], [`SdoData::new`], [`PdoData::new`]).
//!
//! ```
//! use anguilla_protocol::canopen::{decode, Message, NodeId, Object, SdoData, SdoRequest, cia402};
//! // Write the controlword (0x6040:00) of node 1 with "shutdown" (0x0006).
//! let m = Message::SdoRequest {
//!     node: NodeId::new(1)?,
//!     sdo: SdoRequest::Download {
//!         object: Object::new(cia402::CONTROLWORD, 0),
//!         data: SdoData::new(&cia402::Command::Shutdown.word().to_le_bytes())?,
//!     },
//! };
//! let f = m.encode();
//! assert_eq!(f.to_string(), "601#2B40600006000000");
//! assert_eq!(decode(&f)?, m);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Layout: `types.rs` holds the vocabulary and [`Message`], `codec.rs` its
//! encoder and [`decode`], `error.rs` their errors, `cia402.rs` the drive
//! profile's objects and states, `eds.rs` the EDS files.

mod codec;
mod error;
mod types;

pub mod cia402;
pub mod eds;

pub use codec::decode;
pub use error::{DecodeError, EncodeError};
pub use types::*;

/// The cyclic traffic of `axes` CiA 402 drives and their master (classic
/// CAN) for the bus budget: per period an RPDO1 to each drive, SYNC, a
/// TPDO1 from each; heartbeats every 100 ms from every drive and the
/// master.
pub fn traffic(axes: u32) -> Vec<crate::budget::BudgetLine> {
    use crate::budget::{BudgetLine, Cadence};
    use crate::canopen::{Message as Co, NmtState, NodeId as CoNode, Pdo, PdoData};
    let node = CoNode::new(1).expect("1 is a node id");
    let pdo = PdoData::new(&[0; 8]).expect("8 bytes");
    let rpdo = Co::Rpdo {
        node,
        pdo: Pdo::One,
        data: pdo,
    }
    .encode();
    let tpdo = Co::Tpdo {
        node,
        pdo: Pdo::One,
        data: pdo,
    }
    .encode();
    let sync = Co::Sync { counter: None }.encode();
    let hb = Co::Heartbeat {
        node,
        state: NmtState::Operational,
    }
    .encode();
    vec![
        BudgetLine::of("RPDO1", &rpdo, Cadence::PerPeriod(axes)),
        BudgetLine::of("SYNC", &sync, Cadence::PerPeriod(1)),
        BudgetLine::of("TPDO1", &tpdo, Cadence::PerPeriod(axes)),
        BudgetLine::of(
            "Heartbeat",
            &hb,
            Cadence::PerSecond((axes + 1) as f64 * 10.0),
        ),
    ]
}

#[cfg(test)]
mod tests;
