//! The drive's SDO server (CiA 301): expedited and segmented transfers,
//! the checks a write passes (access, size, range, mapping), and what a
//! written object changes.

use super::od::{FLAT, STRING_CAPACITY};
use super::{Cia402Axis, od};
use super::{
    Nmt, RPDO_COMM, S_CONSUMER, S_CONTROLWORD, S_CYCLE_PERIOD, S_MODE, S_MODE_DISPLAY, S_PRODUCER,
    S_SIM_FAULT, Sdo, TPDO_COMM, lookup,
};
use crate::node::Nanos;
use anguilla_protocol::canopen::cia402::{self};
use anguilla_protocol::canopen::{
    AbortCode, Message, Object, SdoData, SdoRequest, SdoResponse, SegmentData,
};
use anguilla_protocol::frame::Frame;

impl Cia402Axis {
    pub(super) fn respond(&self, tx: &mut dyn FnMut(Frame), sdo: SdoResponse) {
        if let Some(node) = self.node {
            self.send(tx, Message::SdoResponse { node, sdo });
        }
    }

    pub(super) fn abort(&mut self, object: Object, code: AbortCode, tx: &mut dyn FnMut(Frame)) {
        self.sdo = Sdo::Idle;
        self.respond(tx, SdoResponse::Abort { object, code });
    }

    pub(super) fn on_sdo(&mut self, req: SdoRequest, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        match req {
            SdoRequest::Abort { .. } => self.sdo = Sdo::Idle,
            SdoRequest::Download { object, data } => {
                self.sdo = Sdo::Idle;
                match self.write(object, data.bytes(), now, tx) {
                    Ok(()) => self.respond(tx, SdoResponse::DownloadAck { object }),
                    Err(code) => self.abort(object, code, tx),
                }
            }
            SdoRequest::Upload { object } => {
                self.sdo = Sdo::Idle;
                let value = match self.read(object) {
                    Ok(v) => v,
                    Err(code) => return self.abort(object, code, tx),
                };
                let bytes = value.bytes();
                if (1..=4).contains(&bytes.len())
                    && let Ok(data) = SdoData::new(bytes)
                {
                    self.respond(tx, SdoResponse::Upload { object, data });
                } else {
                    self.respond(
                        tx,
                        SdoResponse::UploadSegmented {
                            object,
                            size: Some(bytes.len() as u32),
                        },
                    );
                    self.sdo = Sdo::Upload {
                        object,
                        value,
                        sent: 0,
                        toggle: false,
                    };
                }
            }
            SdoRequest::UploadSegment { toggle } => {
                let Sdo::Upload {
                    object,
                    value,
                    sent,
                    toggle: expected,
                } = self.sdo
                else {
                    // No upload in progress: nothing to name but 0:0.
                    return self.abort(Object::new(0, 0), AbortCode::InvalidCommandSpecifier, tx);
                };
                if toggle != expected {
                    return self.abort(object, AbortCode::ToggleBitNotAlternated, tx);
                }
                let rest = value.bytes().get(sent..).unwrap_or(&[]);
                let len = rest.len().min(SegmentData::MAX);
                let Ok(data) = SegmentData::new(&rest[..len]) else {
                    return self.abort(object, AbortCode::GeneralError, tx);
                };
                let last = sent + len == value.bytes().len();
                self.respond(tx, SdoResponse::UploadSegment { toggle, data, last });
                self.sdo = if last {
                    Sdo::Idle
                } else {
                    Sdo::Upload {
                        object,
                        value,
                        sent: sent + len,
                        toggle: !toggle,
                    }
                };
            }
            SdoRequest::DownloadSegmented { object, size } => {
                self.sdo = Sdo::Idle;
                if let Err(code) = self.check_download(object, size) {
                    return self.abort(object, code, tx);
                }
                self.sdo = Sdo::Download {
                    object,
                    size,
                    buf: [0; STRING_CAPACITY],
                    len: 0,
                    toggle: false,
                };
                self.respond(tx, SdoResponse::DownloadAck { object });
            }
            SdoRequest::DownloadSegment { toggle, data, last } => {
                let data = data.bytes();
                let len = data.len();
                let Sdo::Download {
                    object,
                    size,
                    mut buf,
                    len: have,
                    toggle: expected,
                } = self.sdo
                else {
                    // No download in progress: nothing to name but 0:0.
                    return self.abort(Object::new(0, 0), AbortCode::InvalidCommandSpecifier, tx);
                };
                if toggle != expected {
                    return self.abort(object, AbortCode::ToggleBitNotAlternated, tx);
                }
                if have + len > STRING_CAPACITY || size.is_some_and(|s| (have + len) as u32 > s) {
                    return self.abort(object, AbortCode::LengthTooHigh, tx);
                }
                buf[have..have + len].copy_from_slice(data);
                let total = have + len;
                if !last {
                    self.sdo = Sdo::Download {
                        object,
                        size,
                        buf,
                        len: total,
                        toggle: !toggle,
                    };
                    return self.respond(tx, SdoResponse::DownloadSegmentAck { toggle });
                }
                self.sdo = Sdo::Idle;
                if size.is_some_and(|s| s as usize != total) {
                    return self.abort(object, AbortCode::LengthTooLow, tx);
                }
                match self.write(object, &buf[..total], now, tx) {
                    Ok(()) => self.respond(tx, SdoResponse::DownloadSegmentAck { toggle }),
                    Err(code) => self.abort(object, code, tx),
                }
            }
        }
    }

    /// An SDO upload: the value of `object`, or why not.
    pub(super) fn read(&self, object: Object) -> Result<od::Value, AbortCode> {
        let s = lookup(object.index, object.sub)?;
        if !FLAT[s].1.access.readable() {
            return Err(AbortCode::ReadWriteOnly);
        }
        Ok(*self.od.get(s))
    }

    /// The checks an initiate segmented download can make before data.
    pub(super) fn check_download(
        &self,
        object: Object,
        size: Option<u32>,
    ) -> Result<(), AbortCode> {
        let s = lookup(object.index, object.sub)?;
        let e = FLAT[s].1;
        if !e.access.writable() {
            return Err(AbortCode::WriteReadOnly);
        }
        let cap = e.ty.size().unwrap_or(STRING_CAPACITY) as u32;
        match size {
            Some(n) if n > cap => Err(AbortCode::LengthTooHigh),
            Some(n) if e.ty.size().is_some() && n < cap => Err(AbortCode::LengthTooLow),
            _ => Ok(()),
        }
    }

    /// An SDO download of `data` to `object`: access, length and value
    /// checks, then the value and its effects.
    pub(super) fn write(
        &mut self,
        object: Object,
        data: &[u8],
        now: Nanos,
        tx: &mut dyn FnMut(Frame),
    ) -> Result<(), AbortCode> {
        let s = lookup(object.index, object.sub)?;
        let e = FLAT[s].1;
        if !e.access.writable() {
            return Err(AbortCode::WriteReadOnly);
        }
        match e.ty.size() {
            Some(n) if data.len() > n => return Err(AbortCode::LengthTooHigh),
            Some(n) if data.len() < n => return Err(AbortCode::LengthTooLow),
            None if data.len() > STRING_CAPACITY => return Err(AbortCode::LengthTooHigh),
            _ => {}
        }
        let v = od::Value::from_bytes(data).as_i64(e.ty);
        self.check_value(object, v)?;
        self.od.set_bytes(s, data);
        self.on_written(s, now, tx);
        Ok(())
    }

    /// Value checks of the entries whose values are restricted.
    pub(super) fn check_value(&self, object: Object, v: i64) -> Result<(), AbortCode> {
        let Object { index, sub } = object;
        match index {
            cia402::MODES_OF_OPERATION if v != 0 && v != i64::from(cia402::MODE_CSP) => {
                Err(AbortCode::InvalidValue)
            }
            0x605A if v != 2 => Err(AbortCode::InvalidValue),
            0x1400 | 0x1401 | 0x1800 | 0x1801 => match sub {
                1 => {
                    let new = v as u32;
                    let valid = new & (1 << 31) == 0;
                    if new & (1 << 29) != 0 || (valid && new & 0x7FF == 0) {
                        return Err(AbortCode::InvalidValue);
                    }
                    // CiA 301: the COB-ID of an existing PDO cannot change.
                    if valid
                        && let Some(cur) = self.pdo_cob(index)
                        && cur != (new & 0x7FF) as u16
                    {
                        return Err(AbortCode::InvalidValue);
                    }
                    Ok(())
                }
                2 if !matches!(v, 0..=240 | 254 | 255) => Err(AbortCode::InvalidValue),
                _ => Ok(()),
            },
            0x1600 | 0x1601 | 0x1A00 | 0x1A01 => self.check_mapping(index, sub, v as u32),
            _ => Ok(()),
        }
    }

    /// CiA 301's PDO mapping procedure: the PDO must not exist (COB-ID bit
    /// 31 set); entries change only while the count is 0; the count
    /// changes only outside operational, to at most 8 entries of at most
    /// 64 bits, each of a mappable object.
    pub(super) fn check_mapping(&self, map: u16, sub: u8, v: u32) -> Result<(), AbortCode> {
        let receive = map < 0x1800;
        let comm = map - 0x200;
        if self.pdo_cob(comm).is_some() {
            return Err(AbortCode::ParameterIncompatible);
        }
        let count_slot = lookup(map, 0)?;
        if sub == 0 {
            if self.nmt == Nmt::Operational {
                return Err(AbortCode::DeviceState);
            }
            if v > 8 {
                return Err(AbortCode::ValueTooHigh);
            }
            let mut bits = 0;
            for k in 1..=v as u8 {
                let m = self.od.num(lookup(map, k)?) as u32;
                if m == 0 {
                    return Err(AbortCode::ParameterIncompatible);
                }
                bits += m & 0xFF;
            }
            if bits > 64 {
                return Err(AbortCode::PdoLengthExceeded);
            }
            return Ok(());
        }
        if self.od.num(count_slot) != 0 {
            return Err(AbortCode::ParameterIncompatible);
        }
        if v == 0 {
            return Ok(());
        }
        let target =
            lookup((v >> 16) as u16, (v >> 8) as u8).map_err(|_| AbortCode::NotMappable)?;
        let e = FLAT[target].1;
        let direction_ok = if receive {
            e.access.writable()
        } else {
            e.access.readable()
        };
        if !e.pdo || !direction_ok || e.ty.size().map(|n| n * 8) != Some((v & 0xFF) as usize) {
            return Err(AbortCode::NotMappable);
        }
        Ok(())
    }

    /// What a new value of slot `s` does.
    pub(super) fn on_written(&mut self, s: usize, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        match s {
            S_CONTROLWORD => self.on_controlword(tx),
            S_MODE => {
                self.od.set_num(S_MODE_DISPLAY, self.od.num(S_MODE));
                self.refresh_statusword();
            }
            S_PRODUCER => {
                let period = Nanos::from_millis(self.od.num(S_PRODUCER) as u64);
                self.next_heartbeat = (period > Nanos::ZERO).then(|| now + period);
            }
            S_CONSUMER => {
                // CiA 301: monitoring starts at the next heartbeat received.
                self.consumer_last = None;
                self.consumer_expired = false;
            }
            S_CYCLE_PERIOD => self.last_sync = now,
            S_SIM_FAULT => match self.od.num(S_SIM_FAULT) as u16 {
                0 => self.clear_injected_fault(),
                bits => self.inject_fault(bits, now, tx),
            },
            _ => {
                let index = FLAT[s].0;
                for p in 0..2 {
                    if index == RPDO_COMM[p] {
                        self.rpdo_pending[p] = None;
                    }
                    if index == TPDO_COMM[p] {
                        self.tpdo_count[p] = 0;
                        self.tpdo_last[p] = None;
                    }
                }
            }
        }
    }
}
