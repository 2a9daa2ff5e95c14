//! The drive's PDOs (CiA 301): COB-IDs, transmission types and mappings as
//! the dictionary holds them; RPDOs applied at once or at the next SYNC,
//! TPDOs sent on the SYNCs their type asks for.

use super::Cia402Axis;
use super::{
    EMCY_PDO_LENGTH, ERR_COMMUNICATION, ERR_GENERIC, RAD_PER_INCREMENT, RPDO_COMM, RPDO_MAP,
    S_ERROR_REGISTER, S_RATED_TORQUE, S_TARGET, S_TORQUE_OFFSET, S_VELOCITY_OFFSET, TPDO_COMM,
    TPDO_MAP, lookup,
};
use crate::node::Nanos;
use anguilla_protocol::canopen::PdoData;
use anguilla_protocol::canopen::cia402::{self, DriveState};
use anguilla_protocol::frame::Frame;

impl Cia402Axis {
    /// The COB-ID of a PDO whose communication parameter is at `comm`, if
    /// the PDO exists (bit 31 clear).
    pub(super) fn pdo_cob(&self, comm: u16) -> Option<u16> {
        let raw = self.od.num(lookup(comm, 1).ok()?) as u32;
        (raw & (1 << 31) == 0).then_some((raw & 0x7FF) as u16)
    }

    pub(super) fn transmission_type(&self, comm: u16) -> u8 {
        lookup(comm, 2).map_or(0, |s| self.od.num(s) as u8)
    }

    /// The slots and byte sizes of a PDO's mapped objects, in order (at
    /// most 8), and the count.
    pub(super) fn mapping(&self, map: u16) -> ([(usize, usize); 8], usize) {
        let mut out = [(0, 0); 8];
        let Ok(s0) = lookup(map, 0) else {
            return (out, 0);
        };
        let n = (self.od.num(s0) as usize).min(8);
        let mut k = 0;
        for sub in 1..=n {
            let Ok(s) = lookup(map, sub as u8) else {
                continue;
            };
            let m = self.od.num(s) as u32;
            if let Ok(target) = lookup((m >> 16) as u16, (m >> 8) as u8) {
                out[k] = (target, (m & 0xFF) as usize / 8);
                k += 1;
            }
        }
        (out, k)
    }

    pub(super) fn on_rpdo(&mut self, p: usize, data: &[u8], now: Nanos, tx: &mut dyn FnMut(Frame)) {
        let (entries, n) = self.mapping(RPDO_MAP[p]);
        let need: usize = entries[..n].iter().map(|e| e.1).sum();
        if data.len() < need {
            self.counters.bad_frames += 1;
            let reg = self.od.num(S_ERROR_REGISTER) as u8 | ERR_GENERIC | ERR_COMMUNICATION;
            self.emcy(EMCY_PDO_LENGTH, reg, tx);
            return;
        }
        let Ok(pdo) = PdoData::new(&data[..data.len().min(8)]) else {
            return;
        };
        if self.transmission_type(RPDO_COMM[p]) <= 240 {
            if self.rpdo_pending[p].replace(pdo).is_some() {
                self.counters.stale_setpoints += 1;
            }
        } else {
            self.apply_rpdo(p, &pdo, now, tx);
        }
    }

    pub(super) fn apply_rpdo(
        &mut self,
        p: usize,
        pdo: &PdoData,
        now: Nanos,
        tx: &mut dyn FnMut(Frame),
    ) {
        let (entries, n) = self.mapping(RPDO_MAP[p]);
        let data = pdo.bytes();
        let mut at = 0;
        for &(s, size) in &entries[..n] {
            if at + size > data.len() {
                break;
            }
            self.od.set_bytes(s, &data[at..at + size]);
            at += size;
            self.on_written(s, now, tx);
        }
        self.counters.applied += 1;
    }

    pub(super) fn on_sync(&mut self, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        self.last_sync = now;
        for p in 0..2 {
            if let Some(pdo) = self.rpdo_pending[p].take() {
                self.apply_rpdo(p, &pdo, now, tx);
            }
        }
        if self.drive == DriveState::OperationEnabled && self.mode() == cia402::MODE_CSP {
            let rated = self.od.num(S_RATED_TORQUE) as f64;
            self.setpoint = (
                self.od.num(S_TARGET) as f64 * RAD_PER_INCREMENT,
                self.od.num(S_VELOCITY_OFFSET) as f64 * RAD_PER_INCREMENT,
                self.od.num(S_TORQUE_OFFSET) as f64 * rated / 1e6,
            );
        }
        for (p, comm) in TPDO_COMM.into_iter().enumerate() {
            let Some(cob) = self.pdo_cob(comm) else {
                continue;
            };
            let kind = self.transmission_type(comm);
            let pdo = self.tpdo_bytes(p);
            let due = match kind {
                0 => self.tpdo_last[p] != Some(pdo),
                1..=240 => {
                    self.tpdo_count[p] = self.tpdo_count[p].saturating_add(1);
                    self.tpdo_count[p] >= kind
                }
                _ => false,
            };
            if due {
                self.tpdo_count[p] = 0;
                self.tpdo_last[p] = Some(pdo);
                if let Ok(f) = Frame::new_standard(cob, &pdo.0[..pdo.1])
                    && !self.silent
                {
                    tx(f);
                }
            }
        }
    }

    /// The bytes TPDO `p` carries now, and their count.
    pub(super) fn tpdo_bytes(&self, p: usize) -> ([u8; 8], usize) {
        let (entries, n) = self.mapping(TPDO_MAP[p]);
        let mut buf = [0u8; 8];
        let mut at = 0;
        for &(s, size) in &entries[..n] {
            let v = self.od.get(s).bytes();
            if at + size > 8 || v.len() < size {
                break;
            }
            buf[at..at + size].copy_from_slice(&v[..size]);
            at += size;
        }
        (buf, at)
    }
}
