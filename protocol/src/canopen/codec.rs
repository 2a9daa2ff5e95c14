//! [`Message::encode`] and [`decode`], with the byte layouts of CiA 301's
//! SDO, PDO, EMCY, NMT, SYNC and heartbeat frames.

use super::error::DecodeError;
use super::types::{
    AbortCode, EMCY_LEN, Emcy, Function, Message, NmtCommand, NmtState, NodeId, Object, PdoData,
    SDO_LEN, SdoData, SdoRequest, SdoResponse, SegmentData, classify,
};
use crate::frame::{Frame, Id, Kind};

fn sdo_header(d: &mut [u8; 8], command: u8, object: Object) {
    d[0] = command;
    d[1..3].copy_from_slice(&object.index.to_le_bytes());
    d[3] = object.sub;
}

/// The expedited command byte: `cs << 5 | n << 2 | e << 1 | s`, n = 4 − len.
fn expedited(cs: u8, data: &SdoData, d: &mut [u8; 8]) -> u8 {
    d[4..8].copy_from_slice(&data.bytes);
    (cs << 5) | ((4 - data.len) << 2) | 0b11
}

/// A segment's command byte, `cs << 5 | t << 4 | n << 1 | c` with n = 7 −
/// len; its data goes to bytes 1..=7 (the rest stays zero).
fn segment(cs: u8, toggle: bool, data: &SegmentData, last: bool, d: &mut [u8; 8]) -> u8 {
    d[1..1 + data.len as usize].copy_from_slice(data.bytes());
    (cs << 5) | (toggle as u8) << 4 | (7 - data.len) << 1 | last as u8
}

/// The data of a segment: `n` (bits 1-3) counts the unused bytes.
fn segment_data(d: &[u8]) -> SegmentData {
    let len = 7 - ((d[0] >> 1) & 0b111) as usize;
    SegmentData::new(&d[1..1 + len]).expect("0..=7 bytes")
}

impl Message {
    /// The object this message travels on.
    pub const fn function(&self) -> Function {
        match *self {
            Message::Nmt { .. } => Function::Nmt,
            Message::Sync { .. } => Function::Sync,
            Message::Emcy { node, .. } => Function::Emcy(node),
            Message::Tpdo { node, pdo, .. } => Function::Tpdo(pdo, node),
            Message::Rpdo { node, pdo, .. } => Function::Rpdo(pdo, node),
            Message::SdoRequest { node, .. } => Function::SdoRx(node),
            Message::SdoResponse { node, .. } => Function::SdoTx(node),
            Message::Heartbeat { node, .. } => Function::Heartbeat(node),
        }
    }

    /// The classic data frame carrying this message.
    pub fn encode(&self) -> Frame {
        let id = Id::Standard(self.function().cob_id());
        let mut d = [0u8; 8];
        let len = match *self {
            Message::Nmt { command, node } => {
                d[0] = command.raw();
                d[1] = node.map_or(0, NodeId::get);
                2
            }
            Message::Sync { counter } => {
                d[0] = counter.unwrap_or(0);
                counter.is_some() as usize
            }
            Message::Emcy { emcy, .. } => {
                d[0..2].copy_from_slice(&emcy.code.to_le_bytes());
                d[2] = emcy.register;
                d[3..8].copy_from_slice(&emcy.manufacturer);
                8
            }
            Message::Tpdo { data, .. } | Message::Rpdo { data, .. } => {
                d = data.bytes;
                data.len as usize
            }
            Message::SdoRequest { sdo, .. } => {
                match sdo {
                    SdoRequest::Download { object, data } => {
                        let c = expedited(1, &data, &mut d);
                        sdo_header(&mut d, c, object);
                    }
                    SdoRequest::DownloadSegmented { object, size } => {
                        sdo_header(&mut d, 0x20 | size.is_some() as u8, object);
                        d[4..8].copy_from_slice(&size.unwrap_or(0).to_le_bytes());
                    }
                    SdoRequest::DownloadSegment { toggle, data, last } => {
                        d[0] = segment(0, toggle, &data, last, &mut d);
                    }
                    SdoRequest::Upload { object } => sdo_header(&mut d, 0x40, object),
                    SdoRequest::UploadSegment { toggle } => d[0] = 0x60 | (toggle as u8) << 4,
                    SdoRequest::Abort { object, code } => {
                        sdo_header(&mut d, 0x80, object);
                        d[4..8].copy_from_slice(&code.raw().to_le_bytes());
                    }
                }
                8
            }
            Message::SdoResponse { sdo, .. } => {
                match sdo {
                    SdoResponse::DownloadAck { object } => sdo_header(&mut d, 0x60, object),
                    SdoResponse::Upload { object, data } => {
                        let c = expedited(2, &data, &mut d);
                        sdo_header(&mut d, c, object);
                    }
                    SdoResponse::UploadSegmented { object, size } => {
                        sdo_header(&mut d, 0x40 | size.is_some() as u8, object);
                        d[4..8].copy_from_slice(&size.unwrap_or(0).to_le_bytes());
                    }
                    SdoResponse::DownloadSegmentAck { toggle } => d[0] = 0x20 | (toggle as u8) << 4,
                    SdoResponse::UploadSegment { toggle, data, last } => {
                        d[0] = segment(0, toggle, &data, last, &mut d);
                    }
                    SdoResponse::Abort { object, code } => {
                        sdo_header(&mut d, 0x80, object);
                        d[4..8].copy_from_slice(&code.raw().to_le_bytes());
                    }
                }
                8
            }
            Message::Heartbeat { state, .. } => {
                d[0] = state.raw();
                1
            }
        };
        Frame::new(id, &d[..len]).expect("8 bytes or less")
    }
}

fn length(message: &'static str, len: usize, min: u8, max: u8) -> Result<(), DecodeError> {
    if len < min as usize || len > max as usize {
        Err(DecodeError::Length {
            message,
            len: len as u8,
            min,
            max,
        })
    } else {
        Ok(())
    }
}

fn u32_at(d: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([d[at], d[at + 1], d[at + 2], d[at + 3]])
}

fn object_at(d: &[u8]) -> Object {
    Object::new(u16::from_le_bytes([d[1], d[2]]), d[3])
}

/// The data of an expedited transfer: `n` counts the unused bytes when
/// `s` = 1; with `s` = 0 the size is not indicated and all 4 are taken.
fn expedited_data(d: &[u8]) -> SdoData {
    let len = if d[0] & 1 == 1 {
        4 - ((d[0] >> 2) & 0b11) as usize
    } else {
        4
    };
    SdoData::new(&d[4..4 + len]).expect("1..=4 bytes")
}

fn sdo_request(d: &[u8]) -> Result<SdoRequest, DecodeError> {
    const M: &str = "SDO request";
    let object = object_at(d);
    Ok(match d[0] >> 5 {
        1 if d[0] & 0b10 != 0 => SdoRequest::Download {
            object,
            data: expedited_data(d),
        },
        1 => SdoRequest::DownloadSegmented {
            object,
            size: (d[0] & 1 == 1).then(|| u32_at(d, 4)),
        },
        0 => SdoRequest::DownloadSegment {
            toggle: d[0] & 0x10 != 0,
            data: segment_data(d),
            last: d[0] & 1 == 1,
        },
        2 => SdoRequest::Upload { object },
        3 => SdoRequest::UploadSegment {
            toggle: d[0] & 0x10 != 0,
        },
        4 => SdoRequest::Abort {
            object,
            code: AbortCode::from_raw(u32_at(d, 4)),
        },
        _ => {
            return Err(DecodeError::SdoCommand {
                message: M,
                command: d[0],
                expected: "a download 0x2_, download segment 0x0_/0x1_, upload 0x40, \
                           upload segment 0x60/0x70 or abort 0x80",
            });
        }
    })
}

fn sdo_response(d: &[u8]) -> Result<SdoResponse, DecodeError> {
    const M: &str = "SDO response";
    let object = object_at(d);
    Ok(match d[0] >> 5 {
        3 => SdoResponse::DownloadAck { object },
        2 if d[0] & 0b10 != 0 => SdoResponse::Upload {
            object,
            data: expedited_data(d),
        },
        2 => SdoResponse::UploadSegmented {
            object,
            size: (d[0] & 1 == 1).then(|| u32_at(d, 4)),
        },
        1 => SdoResponse::DownloadSegmentAck {
            toggle: d[0] & 0x10 != 0,
        },
        0 => SdoResponse::UploadSegment {
            toggle: d[0] & 0x10 != 0,
            data: segment_data(d),
            last: d[0] & 1 == 1,
        },
        4 => SdoResponse::Abort {
            object,
            code: AbortCode::from_raw(u32_at(d, 4)),
        },
        _ => {
            return Err(DecodeError::SdoCommand {
                message: M,
                command: d[0],
                expected: "a download response 0x60, segment response 0x20/0x30, \
                           upload response 0x4_, upload segment 0x0_/0x1_ or abort 0x80",
            });
        }
    })
}

/// The message a classic 11-bit data frame carries.
pub fn decode(frame: &Frame) -> Result<Message, DecodeError> {
    let raw = frame
        .id()
        .as_standard()
        .ok_or(DecodeError::ExtendedId(frame.id().raw()))?;
    match frame.kind() {
        Kind::Fd { .. } => return Err(DecodeError::FdFrame(raw)),
        Kind::Remote { .. } => return Err(DecodeError::RemoteFrame(raw)),
        Kind::Data => {}
    }
    let d = frame.data();
    Ok(match classify(raw)? {
        Function::Nmt => {
            const M: &str = "NMT";
            length(M, d.len(), 2, 2)?;
            Message::Nmt {
                command: NmtCommand::from_raw(M, d[0])?,
                node: match d[1] {
                    0 => None,
                    n => Some(NodeId::new(n).map_err(|_| DecodeError::UnknownValue {
                        message: M,
                        field: "node",
                        raw: n as u32,
                        expected: "0 (all) or a node id 1..=127",
                    })?),
                },
            }
        }
        Function::Sync => {
            length("SYNC", d.len(), 0, 1)?;
            Message::Sync {
                counter: d.first().copied(),
            }
        }
        Function::Emcy(node) => {
            length("EMCY", d.len(), EMCY_LEN, EMCY_LEN)?;
            Message::Emcy {
                node,
                emcy: Emcy {
                    code: u16::from_le_bytes([d[0], d[1]]),
                    register: d[2],
                    manufacturer: [d[3], d[4], d[5], d[6], d[7]],
                },
            }
        }
        Function::Tpdo(pdo, node) => Message::Tpdo {
            node,
            pdo,
            data: PdoData::new(d).expect("a classic frame holds 8 bytes or less"),
        },
        Function::Rpdo(pdo, node) => Message::Rpdo {
            node,
            pdo,
            data: PdoData::new(d).expect("a classic frame holds 8 bytes or less"),
        },
        Function::SdoRx(node) => {
            length("SDO request", d.len(), SDO_LEN, SDO_LEN)?;
            Message::SdoRequest {
                node,
                sdo: sdo_request(d)?,
            }
        }
        Function::SdoTx(node) => {
            length("SDO response", d.len(), SDO_LEN, SDO_LEN)?;
            Message::SdoResponse {
                node,
                sdo: sdo_response(d)?,
            }
        }
        Function::Heartbeat(node) => {
            const M: &str = "heartbeat";
            length(M, d.len(), 1, 1)?;
            Message::Heartbeat {
                node,
                state: NmtState::from_raw(M, d[0])?,
            }
        }
    })
}
