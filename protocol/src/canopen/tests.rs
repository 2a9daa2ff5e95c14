//! Byte-exact vectors, every decode error, the CiA 402 tables, round trips.
//!
//! The expected bytes are written out by hand from the layouts of CiA 301
//! v4.2: the COB-IDs from the pre-defined connection set (function code
//! << 7 | node), the SDO command byte from the initiate download / upload
//! protocols (`ccs`/`scs` in bits 5-7, `n` in bits 2-3, `e` bit 1, `s`
//! bit 0, so 0x2B is "download, 2 bytes", 0x4B "upload response, 2
//! bytes"), index little-endian in bytes 1-2, subindex
//! byte 3, data or abort code in bytes 4-7; EMCY from its write protocol;
//! NMT and heartbeat from their protocols. The abort codes and the CiA 402
//! EMCY codes were checked against published tables (vendor manuals
//! reproducing CiA 301's abort table; openCANopen's
//! `cia402-error-codes.h`). The statusword patterns are CiA 402-2's state
//! table (mask 0x4F / 0x6F). None is produced by this codec first and
//! pasted back.

use super::cia402::{Command, DriveState};
use super::*;
use crate::frame::{Frame, Id};
use proptest::prelude::*;

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

/// Encodes, checks the `cansend` text, and checks it decodes back.
fn vector(m: Message, expected: &str) {
    let f = m.encode();
    assert_eq!(f.to_string(), expected, "{m:?}");
    assert_eq!(decode(&f).unwrap(), m, "{expected}");
}

fn data(id: u16, d: &[u8]) -> Frame {
    Frame::new_standard(id, d).unwrap()
}

fn sdo(d: &[u8]) -> SdoData {
    SdoData::new(d).unwrap()
}

#[test]
fn node_ids_are_1_to_127() {
    assert_eq!(NodeId::new(0), Err(EncodeError::NodeOutOfRange(0)));
    assert_eq!(NodeId::new(128), Err(EncodeError::NodeOutOfRange(128)));
    assert_eq!(
        NodeId::new(0).unwrap_err().to_string(),
        "CANopen node id 0 is out of range (expected 1..=127)"
    );
    assert_eq!(node(127).get(), 127);
    assert_eq!(node(1).get(), 1);
}

#[test]
fn the_predefined_connection_set() {
    // CiA 301's pre-defined connection set, for node 1 and node 127.
    let n1 = node(1);
    let n127 = node(127);
    let table = [
        (Function::Nmt, 0x000),
        (Function::Sync, 0x080),
        (Function::Emcy(n1), 0x081),
        (Function::Tpdo(Pdo::One, n1), 0x181),
        (Function::Rpdo(Pdo::One, n1), 0x201),
        (Function::Tpdo(Pdo::Two, n1), 0x281),
        (Function::Rpdo(Pdo::Two, n1), 0x301),
        (Function::Tpdo(Pdo::Three, n1), 0x381),
        (Function::Rpdo(Pdo::Three, n1), 0x401),
        (Function::Tpdo(Pdo::Four, n1), 0x481),
        (Function::Rpdo(Pdo::Four, n1), 0x501),
        (Function::SdoTx(n1), 0x581),
        (Function::SdoRx(n1), 0x601),
        (Function::Heartbeat(n1), 0x701),
        (Function::Emcy(n127), 0x0FF),
        (Function::Tpdo(Pdo::One, n127), 0x1FF),
        (Function::Rpdo(Pdo::Four, n127), 0x57F),
        (Function::SdoTx(n127), 0x5FF),
        (Function::SdoRx(n127), 0x67F),
        (Function::Heartbeat(n127), 0x77F),
    ];
    for (function, id) in table {
        assert_eq!(function.cob_id().as_raw(), id, "{function:?}");
        assert_eq!(classify(id), Ok(function), "0x{id:03X}");
    }
    // Every one of the 2048 ids either classifies to an object whose
    // COB-ID is that id, or is not in the set; NMT, SYNC and 12 objects
    // per node (EMCY, 4 TPDOs, 4 RPDOs, 2 SDOs, heartbeat) are.
    let mut known = 0;
    for id in 0..=0x7FFu16 {
        if let Ok(f) = classify(id) {
            assert_eq!(f.cob_id().as_raw(), id);
            known += 1;
        }
    }
    assert_eq!(known, 2 + 12 * 127);
    for id in [
        0x001, 0x07F, 0x100, 0x17F, 0x180, 0x200, 0x580, 0x600, 0x681, 0x700, 0x7E5,
    ] {
        assert_eq!(
            classify(id),
            Err(DecodeError::UnknownCobId(id)),
            "0x{id:03X}"
        );
    }
    assert_eq!(classify(0x800), Err(DecodeError::UnknownCobId(0x800)));
}

#[test]
fn nmt_vectors() {
    // [command, node]; node 0 addresses all nodes.
    let nmt = |command, node| Message::Nmt { command, node };
    vector(nmt(NmtCommand::Start, None), "000#0100");
    vector(nmt(NmtCommand::Start, Some(node(1))), "000#0101");
    vector(nmt(NmtCommand::Stop, Some(node(2))), "000#0202");
    vector(nmt(NmtCommand::EnterPreOperational, None), "000#8000");
    vector(nmt(NmtCommand::ResetNode, Some(node(127))), "000#817F");
    vector(nmt(NmtCommand::ResetCommunication, None), "000#8200");
}

#[test]
fn sync_heartbeat_and_emcy_vectors() {
    vector(Message::Sync { counter: None }, "080#");
    vector(Message::Sync { counter: Some(5) }, "080#05");
    let hb = |n, state| Message::Heartbeat {
        node: node(n),
        state,
    };
    vector(hb(1, NmtState::BootUp), "701#00");
    vector(hb(1, NmtState::Stopped), "701#04");
    vector(hb(1, NmtState::Operational), "701#05");
    vector(hb(127, NmtState::PreOperational), "77F#7F");
    // Code 0x8611 (CiA 402 following error) little-endian, error register
    // 0x21 (bit 0 generic, bit 5 device profile specific), 5 vendor bytes.
    let m = Message::Emcy {
        node: node(2),
        emcy: Emcy {
            code: 0x8611,
            register: 0x21,
            manufacturer: [1, 2, 3, 4, 5],
        },
    };
    vector(m, "082#1186210102030405");
    // The error reset EMCY: all zeros.
    vector(
        Message::Emcy {
            node: node(2),
            emcy: Emcy {
                code: 0,
                register: 0,
                manufacturer: [0; 5],
            },
        },
        "082#0000000000000000",
    );
}

#[test]
fn emcy_classes() {
    let class = |code| {
        Emcy {
            code,
            register: 0,
            manufacturer: [0; 5],
        }
        .class()
    };
    for (code, expected) in [
        (0x0000, EmcyClass::NoError),
        (0x1000, EmcyClass::Generic),
        (0x2310, EmcyClass::Current),
        (0x3210, EmcyClass::Voltage),
        (0x3220, EmcyClass::Voltage),
        (0x4310, EmcyClass::Temperature),
        (0x5000, EmcyClass::DeviceHardware),
        (0x6100, EmcyClass::DeviceSoftware),
        (0x7305, EmcyClass::AdditionalModules),
        (0x8130, EmcyClass::Monitoring),
        (0x8611, EmcyClass::Monitoring),
        (0x9000, EmcyClass::External),
        (0xF000, EmcyClass::AdditionalFunctions),
        (0xFF01, EmcyClass::DeviceSpecific),
        (0x0100, EmcyClass::Unassigned),
        (0x1100, EmcyClass::Unassigned),
        (0xA000, EmcyClass::Unassigned),
        (0xF100, EmcyClass::Unassigned),
    ] {
        assert_eq!(class(code), expected, "0x{code:04X}");
    }
}

#[test]
fn pdo_vectors() {
    vector(
        Message::Tpdo {
            node: node(5),
            pdo: Pdo::One,
            data: PdoData::new(&[0x37, 0x02, 0xE8, 0x03, 0, 0]).unwrap(),
        },
        "185#3702E8030000",
    );
    vector(
        Message::Rpdo {
            node: node(127),
            pdo: Pdo::Four,
            data: PdoData::new(&[]).unwrap(),
        },
        "57F#",
    );
    assert_eq!(
        PdoData::new(&[0; 9]),
        Err(EncodeError::PayloadLength {
            message: "PDO",
            len: 9,
            min: 0,
            max: 8
        })
    );
}

#[test]
fn sdo_request_vectors() {
    let req = |sdo| Message::SdoRequest { node: node(1), sdo };
    let ctl = Object::new(cia402::CONTROLWORD, 0);
    // Download 4/3/2/1 bytes: 0x23/0x27/0x2B/0x2F (n = 0..=3 unused bytes).
    vector(
        req(SdoRequest::Download {
            object: Object::new(cia402::TARGET_POSITION, 0),
            data: sdo(&1000i32.to_le_bytes()),
        }),
        "601#237A6000E8030000",
    );
    vector(
        req(SdoRequest::Download {
            object: Object::new(0x2000, 1),
            data: sdo(&[1, 2, 3]),
        }),
        "601#2700200101020300",
    );
    vector(
        req(SdoRequest::Download {
            object: ctl,
            data: sdo(&[0x0F, 0x00]),
        }),
        "601#2B4060000F000000",
    );
    vector(
        req(SdoRequest::Download {
            object: Object::new(cia402::MODES_OF_OPERATION, 0),
            data: sdo(&[cia402::MODE_CSP as u8]),
        }),
        "601#2F60600008000000",
    );
    vector(
        req(SdoRequest::Upload {
            object: Object::new(cia402::STATUSWORD, 0),
        }),
        "601#4041600000000000",
    );
    // Abort 0x0609_0030 little-endian in bytes 4-7.
    vector(
        req(SdoRequest::Abort {
            object: ctl,
            code: AbortCode::InvalidValue,
        }),
        "601#8040600030000906",
    );
    // e = 1, s = 0: size not indicated, the 4 bytes are taken.
    assert_eq!(
        decode(&data(0x601, &[0x22, 0x40, 0x60, 0, 6, 0, 0, 0])).unwrap(),
        req(SdoRequest::Download {
            object: ctl,
            data: sdo(&[6, 0, 0, 0])
        })
    );
    assert_eq!(sdo(&[6, 0]).as_u32(), 6);
    assert!(SdoData::new(&[]).is_err());
    assert_eq!(
        SdoData::new(&[0; 5]).unwrap_err().to_string(),
        "expedited SDO payload of 5 bytes (expected 1..=4)"
    );
}

#[test]
fn sdo_response_vectors() {
    let resp = |sdo| Message::SdoResponse { node: node(1), sdo };
    let status = Object::new(cia402::STATUSWORD, 0);
    vector(
        resp(SdoResponse::DownloadAck {
            object: Object::new(cia402::CONTROLWORD, 0),
        }),
        "581#6040600000000000",
    );
    // Statusword 0x0237: operation enabled, voltage enabled, remote.
    vector(
        resp(SdoResponse::Upload {
            object: status,
            data: sdo(&[0x37, 0x02]),
        }),
        "581#4B41600037020000",
    );
    vector(
        resp(SdoResponse::Upload {
            object: Object::new(cia402::POSITION_ACTUAL, 0),
            data: sdo(&(-2i32).to_le_bytes()),
        }),
        "581#43646000FEFFFFFF",
    );
    // Segmented initiate upload response of 0x1008 (device name), size 20
    // indicated (0x41) and not (0x40).
    vector(
        resp(SdoResponse::UploadSegmented {
            object: Object::new(0x1008, 0),
            size: Some(20),
        }),
        "581#4108100014000000",
    );
    vector(
        resp(SdoResponse::UploadSegmented {
            object: Object::new(0x1008, 0),
            size: None,
        }),
        "581#4008100000000000",
    );
    vector(
        resp(SdoResponse::Abort {
            object: Object::new(0x6099, 0),
            code: AbortCode::ObjectDoesNotExist,
        }),
        "581#8099600000000206",
    );
    vector(
        resp(SdoResponse::Abort {
            object: status,
            code: AbortCode::Other(0x1234_5678),
        }),
        "581#8041600078563412",
    );
}

fn seg(b: &[u8]) -> SegmentData {
    SegmentData::new(b).unwrap()
}

#[test]
fn segmented_sdo_vectors() {
    let req = |sdo| Message::SdoRequest { node: node(1), sdo };
    let resp = |sdo| Message::SdoResponse { node: node(1), sdo };
    // Initiate segmented download of 0x1008, 12 bytes indicated (0x21).
    vector(
        req(SdoRequest::DownloadSegmented {
            object: Object::new(0x1008, 0),
            size: Some(12),
        }),
        "601#210810000C000000",
    );
    vector(
        req(SdoRequest::DownloadSegmented {
            object: Object::new(0x1008, 0),
            size: None,
        }),
        "601#2008100000000000",
    );
    // First segment: t = 0, 7 bytes (n = 0), more follow (c = 0).
    vector(
        req(SdoRequest::DownloadSegment {
            toggle: false,
            data: seg(b"anguill"),
            last: false,
        }),
        "601#00616E6775696C6C",
    );
    // Second: t = 1, 5 bytes (n = 2), last: 0x10 | 2 << 1 | 1 = 0x15.
    vector(
        req(SdoRequest::DownloadSegment {
            toggle: true,
            data: seg(b"a sim"),
            last: true,
        }),
        "601#15612073696D0000",
    );
    vector(
        req(SdoRequest::UploadSegment { toggle: false }),
        "601#6000000000000000",
    );
    vector(
        req(SdoRequest::UploadSegment { toggle: true }),
        "601#7000000000000000",
    );
    vector(
        resp(SdoResponse::DownloadSegmentAck { toggle: false }),
        "581#2000000000000000",
    );
    vector(
        resp(SdoResponse::DownloadSegmentAck { toggle: true }),
        "581#3000000000000000",
    );
    vector(
        resp(SdoResponse::UploadSegment {
            toggle: false,
            data: seg(b"anguill"),
            last: false,
        }),
        "581#00616E6775696C6C",
    );
    // t = 1, 3 bytes (n = 4), last: 0x10 | 4 << 1 | 1 = 0x19.
    vector(
        resp(SdoResponse::UploadSegment {
            toggle: true,
            data: seg(b"a s"),
            last: true,
        }),
        "581#1961207300000000",
    );
    // An empty last segment (n = 7).
    vector(
        resp(SdoResponse::UploadSegment {
            toggle: false,
            data: seg(b""),
            last: true,
        }),
        "581#0F00000000000000",
    );
    assert!(SegmentData::new(&[0; 8]).is_err());
}

#[test]
fn abort_codes_are_the_cia_301_table() {
    assert_eq!(AbortCode::NAMED.len(), 31);
    for &c in AbortCode::NAMED {
        assert_eq!(AbortCode::from_raw(c.raw()), c);
        assert!(!matches!(c, AbortCode::Other(_)));
        assert_ne!(c.description(), "unknown abort code");
    }
    assert_eq!(
        AbortCode::from_raw(0x0503_0000),
        AbortCode::ToggleBitNotAlternated
    );
    assert_eq!(AbortCode::from_raw(0x0800_0024), AbortCode::NoDataAvailable);
    assert_eq!(AbortCode::SubIndexDoesNotExist.raw(), 0x0609_0011);
    assert_eq!(
        AbortCode::from_raw(0x0503_0001),
        AbortCode::Other(0x0503_0001)
    );
    assert_eq!(
        AbortCode::WriteReadOnly.description(),
        "attempt to write a read only object"
    );
}

#[test]
fn every_decode_error() {
    let ext = Frame::new(Id::extended_literal(0x601), &[0; 8]).unwrap();
    assert_eq!(decode(&ext), Err(DecodeError::ExtendedId(0x601)));
    let fd = Frame::new_fd(Id::standard_literal(0x601), &[0; 8], false).unwrap();
    assert_eq!(decode(&fd), Err(DecodeError::FdFrame(0x601)));
    // Node guarding: a remote frame on 0x700 + n.
    let rtr = Frame::new_remote(Id::standard_literal(0x701), 1).unwrap();
    assert_eq!(decode(&rtr), Err(DecodeError::RemoteFrame(0x701)));
    assert_eq!(
        decode(&data(0x100, &[0; 6])),
        Err(DecodeError::UnknownCobId(0x100))
    );
    let len = |message, len, min, max| {
        Err(DecodeError::Length {
            message,
            len,
            min,
            max,
        })
    };
    assert_eq!(decode(&data(0x000, &[1])), len("NMT", 1, 2, 2));
    assert_eq!(decode(&data(0x080, &[1, 2])), len("SYNC", 2, 0, 1));
    assert_eq!(decode(&data(0x081, &[0; 7])), len("EMCY", 7, 8, 8));
    assert_eq!(
        decode(&data(0x601, &[0x40; 7])),
        len("SDO request", 7, 8, 8)
    );
    assert_eq!(
        decode(&data(0x581, &[0x60; 4])),
        len("SDO response", 4, 8, 8)
    );
    assert_eq!(decode(&data(0x701, &[])), len("heartbeat", 0, 1, 1));
    assert_eq!(decode(&data(0x701, &[5, 0])), len("heartbeat", 2, 1, 1));
    assert_eq!(
        decode(&data(0x000, &[0x03, 0])),
        Err(DecodeError::UnknownValue {
            message: "NMT",
            field: "command",
            raw: 3,
            expected: "0x01, 0x02, 0x80, 0x81 or 0x82"
        })
    );
    assert!(matches!(
        decode(&data(0x000, &[0x01, 0x80])),
        Err(DecodeError::UnknownValue {
            field: "node",
            raw: 0x80,
            ..
        })
    ));
    let e = decode(&data(0x701, &[0x06])).unwrap_err();
    assert_eq!(
        e.to_string(),
        "heartbeat.state value 0x06 is unknown (expected 0x00, 0x04, 0x05 or 0x7F)"
    );
    // Block download (ccs 6) and block upload (ccs 5) requests; block
    // responses (scs 5, 6, 7); not implemented.
    for c in [0xC0u8, 0xA0, 0xE0] {
        assert!(
            matches!(
                decode(&data(0x601, &[c, 0, 0x10, 0, 0, 0, 0, 0])),
                Err(DecodeError::SdoCommand { message: "SDO request", command, .. }) if command == c
            ),
            "0x{c:02X}"
        );
    }
    for c in [0xC0u8, 0xA0, 0xE0] {
        assert!(
            matches!(
                decode(&data(0x581, &[c, 0, 0x10, 0, 0, 0, 0, 0])),
                Err(DecodeError::SdoCommand { message: "SDO response", command, .. }) if command == c
            ),
            "0x{c:02X}"
        );
    }
    assert_eq!(
        decode(&data(0x581, &[0xC0, 0, 0x10, 0, 0, 0, 0, 0]))
            .unwrap_err()
            .to_string(),
        "SDO response command byte 0xC0 is not implemented (expected a download response \
         0x60, segment response 0x20/0x30, upload response 0x4_, upload segment 0x0_/0x1_ or \
         abort 0x80)"
    );
    assert_eq!(
        DriveState::from_statusword(0x0001),
        Err(DecodeError::Statusword(0x0001))
    );
    assert_eq!(
        DecodeError::UnknownCobId(0x100).to_string().get(..52),
        Some("COB-ID 0x100 is not in the predefined connection set")
    );
}

#[test]
fn the_statusword_table() {
    // CiA 402-2 state table; the "x" bits set to show they are ignored:
    // bit 4 voltage enabled, bit 7 warning, bit 9 remote, bits 8, 10-15.
    for (state, word) in [
        (DriveState::NotReadyToSwitchOn, 0x0000),
        (DriveState::NotReadyToSwitchOn, 0xFFB0),
        (DriveState::SwitchOnDisabled, 0x0040),
        (DriveState::SwitchOnDisabled, 0x0250),
        (DriveState::SwitchOnDisabled, 0xFFF0),
        (DriveState::ReadyToSwitchOn, 0x0021),
        (DriveState::ReadyToSwitchOn, 0x0231),
        (DriveState::SwitchedOn, 0x0023),
        (DriveState::SwitchedOn, 0x0233),
        (DriveState::OperationEnabled, 0x0027),
        (DriveState::OperationEnabled, 0x0237),
        (DriveState::OperationEnabled, 0xFFB7),
        (DriveState::QuickStopActive, 0x0007),
        (DriveState::QuickStopActive, 0x0217),
        (DriveState::FaultReactionActive, 0x000F),
        (DriveState::FaultReactionActive, 0x003F),
        (DriveState::Fault, 0x0008),
        (DriveState::Fault, 0x0228),
    ] {
        assert_eq!(DriveState::from_statusword(word), Ok(state), "0x{word:04X}");
    }
    // Patterns do not overlap: no word matches two states; counting the
    // free bits (16 − 5 under 0x4F, 16 − 6 under 0x6F), 4 × 2^11 + 4 × 2^10
    // of the 65536 words name a state.
    let mut named = 0u32;
    for word in 0..=u16::MAX {
        let matches = DriveState::ALL
            .iter()
            .filter(|s| word & s.pattern().0 == s.pattern().1)
            .count();
        assert!(matches <= 1, "0x{word:04X}");
        named += matches as u32;
        assert_eq!(DriveState::from_statusword(word).is_ok(), matches == 1);
    }
    assert_eq!(named, 4 * 2048 + 4 * 1024);
}

#[test]
fn controlword_commands() {
    for (c, w) in [
        (Command::Shutdown, 0x06),
        (Command::SwitchOn, 0x07),
        (Command::EnableOperation, 0x0F),
        (Command::DisableVoltage, 0x00),
        (Command::QuickStop, 0x02),
        (Command::FaultReset, 0x80),
    ] {
        assert_eq!(c.word(), w, "{c:?}");
    }
}

/// The CiA 402-2 transitions a drive makes on a command (a model written
/// from the standard's state diagram, independent of the code under test);
/// `None` where the command does not apply in that state.
fn drive_model(state: DriveState, c: Command) -> Option<DriveState> {
    use DriveState::*;
    match (state, c) {
        (SwitchOnDisabled, Command::Shutdown) => Some(ReadyToSwitchOn), // 2
        (ReadyToSwitchOn, Command::SwitchOn) => Some(SwitchedOn),       // 3
        (SwitchedOn, Command::EnableOperation) => Some(OperationEnabled), // 4
        (OperationEnabled, Command::EnableOperation) => Some(OperationEnabled),
        (QuickStopActive, Command::DisableVoltage) => Some(SwitchOnDisabled), // 12
        (Fault, Command::FaultReset) => Some(SwitchOnDisabled),               // 15
        _ => None,
    }
}

/// Transitions the drive makes by itself (0→1, 13→14).
fn drive_auto(state: DriveState) -> DriveState {
    match state {
        DriveState::NotReadyToSwitchOn => DriveState::SwitchOnDisabled,
        DriveState::FaultReactionActive => DriveState::Fault,
        s => s,
    }
}

#[test]
fn the_path_to_operation_enabled_from_every_state() {
    let expected = [
        (DriveState::NotReadyToSwitchOn, None),
        (DriveState::SwitchOnDisabled, Some(Command::Shutdown)),
        (DriveState::ReadyToSwitchOn, Some(Command::SwitchOn)),
        (DriveState::SwitchedOn, Some(Command::EnableOperation)),
        (DriveState::OperationEnabled, Some(Command::EnableOperation)),
        (DriveState::QuickStopActive, Some(Command::DisableVoltage)),
        (DriveState::FaultReactionActive, None),
        (DriveState::Fault, Some(Command::FaultReset)),
    ];
    for (state, next) in expected {
        assert_eq!(state.next_toward_enabled(), next, "{state:?}");
    }
    // Following the advice reaches Operation enabled from every state
    // within 5 steps (Fault reaction → Fault → SOD → RTSO → SO → OE), and
    // every advised command is one the state accepts.
    for start in DriveState::ALL {
        let mut state = start;
        let mut steps = 0;
        while state != DriveState::OperationEnabled {
            state = match state.next_toward_enabled() {
                Some(c) => drive_model(state, c).unwrap_or_else(|| panic!("{c:?} in {state:?}")),
                None => drive_auto(state),
            };
            steps += 1;
            assert!(steps <= 5, "from {start:?}");
        }
        let hold = state.next_toward_enabled().unwrap();
        assert_eq!(drive_model(state, hold), Some(DriveState::OperationEnabled));
    }
}

fn arb_node() -> impl Strategy<Value = NodeId> {
    (1u8..=127).prop_map(node)
}

fn arb_object() -> impl Strategy<Value = Object> {
    (any::<u16>(), any::<u8>()).prop_map(|(i, s)| Object::new(i, s))
}

fn arb_sdo_data() -> impl Strategy<Value = SdoData> {
    prop::collection::vec(any::<u8>(), 1..=4).prop_map(|v| sdo(&v))
}

fn arb_pdo() -> impl Strategy<Value = (Pdo, PdoData)> {
    (
        prop::sample::select(Pdo::ALL.to_vec()),
        prop::collection::vec(any::<u8>(), 0..=8),
    )
        .prop_map(|(p, v)| (p, PdoData::new(&v).unwrap()))
}

fn arb_abort() -> impl Strategy<Value = AbortCode> {
    any::<u32>().prop_map(AbortCode::from_raw)
}

fn arb_segment() -> impl Strategy<Value = SegmentData> {
    prop::collection::vec(any::<u8>(), 0..=7).prop_map(|b| SegmentData::new(&b).unwrap())
}

fn arb_message() -> impl Strategy<Value = Message> {
    prop_oneof![
        (
            prop::sample::select(NmtCommand::ALL.to_vec()),
            prop::option::of(arb_node())
        )
            .prop_map(|(command, node)| Message::Nmt { command, node }),
        prop::option::of(any::<u8>()).prop_map(|counter| Message::Sync { counter }),
        (arb_node(), any::<u16>(), any::<u8>(), any::<[u8; 5]>()).prop_map(
            |(node, code, register, manufacturer)| Message::Emcy {
                node,
                emcy: Emcy {
                    code,
                    register,
                    manufacturer
                }
            }
        ),
        (arb_node(), arb_pdo()).prop_map(|(node, (pdo, data))| Message::Tpdo { node, pdo, data }),
        (arb_node(), arb_pdo()).prop_map(|(node, (pdo, data))| Message::Rpdo { node, pdo, data }),
        (
            arb_node(),
            prop_oneof![
                (arb_object(), arb_sdo_data())
                    .prop_map(|(object, data)| SdoRequest::Download { object, data }),
                arb_object().prop_map(|object| SdoRequest::Upload { object }),
                (arb_object(), prop::option::of(any::<u32>()))
                    .prop_map(|(object, size)| SdoRequest::DownloadSegmented { object, size }),
                (any::<bool>(), arb_segment(), any::<bool>()).prop_map(|(toggle, data, last)| {
                    SdoRequest::DownloadSegment { toggle, data, last }
                }),
                any::<bool>().prop_map(|toggle| SdoRequest::UploadSegment { toggle }),
                (arb_object(), arb_abort())
                    .prop_map(|(object, code)| SdoRequest::Abort { object, code }),
            ]
        )
            .prop_map(|(node, sdo)| Message::SdoRequest { node, sdo }),
        (
            arb_node(),
            prop_oneof![
                arb_object().prop_map(|object| SdoResponse::DownloadAck { object }),
                (arb_object(), arb_sdo_data())
                    .prop_map(|(object, data)| SdoResponse::Upload { object, data }),
                (arb_object(), prop::option::of(any::<u32>()))
                    .prop_map(|(object, size)| SdoResponse::UploadSegmented { object, size }),
                (arb_object(), arb_abort())
                    .prop_map(|(object, code)| SdoResponse::Abort { object, code }),
                any::<bool>().prop_map(|toggle| SdoResponse::DownloadSegmentAck { toggle }),
                (any::<bool>(), arb_segment(), any::<bool>()).prop_map(|(toggle, data, last)| {
                    SdoResponse::UploadSegment { toggle, data, last }
                }),
            ]
        )
            .prop_map(|(node, sdo)| Message::SdoResponse { node, sdo }),
        (arb_node(), prop::sample::select(NmtState::ALL.to_vec()))
            .prop_map(|(node, state)| Message::Heartbeat { node, state }),
    ]
}

proptest! {
    #[test]
    fn every_message_round_trips(m in arb_message()) {
        let f = m.encode();
        prop_assert_eq!(f.id().as_standard(), Some(m.function().cob_id().as_raw()));
        prop_assert_eq!(decode(&f), Ok(m));
    }

    /// Any classic data frame either fails to decode or decodes to a
    /// message whose encoding decodes to the same message.
    #[test]
    fn any_frame_decodes_or_errors(id in 0u16..=0x7FF, d in prop::collection::vec(any::<u8>(), 0..=8)) {
        let f = data(id, &d);
        if let Ok(m) = decode(&f) {
            prop_assert_eq!(decode(&m.encode()), Ok(m));
            prop_assert_eq!(m.function(), classify(id).unwrap());
        }
    }
}

#[test]
fn the_csp_pdos_are_laid_out_as_their_mapping_entries_say() {
    use super::cia402::{CSP_RPDO1, CSP_TPDO1, CspCommand, CspStatus};
    // Each entry's bit length, in order, fills the 8 bytes exactly.
    for mapping in [CSP_RPDO1, CSP_TPDO1] {
        let bits: Vec<u32> = mapping.iter().map(|e| e & 0xFF).collect();
        assert_eq!(bits, vec![16, 32, 16]);
    }
    assert_eq!(CSP_RPDO1, [0x6040_0010, 0x607A_0020, 0x60B2_0010]);
    assert_eq!(CSP_TPDO1, [0x6041_0010, 0x6064_0020, 0x6077_0010]);
    // Controlword 0x000F, target −2, torque offset 400 ‰, little-endian.
    let c = CspCommand {
        controlword: 0x000F,
        target: -2,
        torque_offset: 400,
    };
    assert_eq!(
        c.to_pdo().bytes(),
        &[0x0F, 0x00, 0xFE, 0xFF, 0xFF, 0xFF, 0x90, 0x01]
    );
    assert_eq!(CspCommand::from_pdo(&c.to_pdo()), Some(c));
    let s = CspStatus {
        statusword: 0x0237,
        position: 65536,
        torque: -1,
    };
    assert_eq!(
        s.to_pdo().bytes(),
        &[0x37, 0x02, 0x00, 0x00, 0x01, 0x00, 0xFF, 0xFF]
    );
    assert_eq!(CspStatus::from_pdo(&s.to_pdo()), Some(s));
    assert_eq!(CspStatus::from_pdo(&PdoData::new(&[0; 7]).unwrap()), None);
}
