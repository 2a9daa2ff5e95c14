//! A drive's configuration over SDO, step by step: what the master reads
//! and checks (profile 402, name, rated torque, CSP), what it writes
//! (heartbeats, SYNC watchdog, PDO mappings, mode), the retries and
//! timeouts, and the answers it judges.

use super::{
    Axis, Check, ConfigFailure, HEARTBEAT_MS, Master, NAME_LEN, SDO_ATTEMPTS, Setup, Step, word,
};
use crate::drive::Out;
use anguilla_ipc::vocabulary::Nanos;
use anguilla_protocol::canopen::{
    AbortCode, Message, NmtCommand, Object, SdoRequest, SdoResponse, cia402,
};

impl Master {
    /// Step `i` of drive `a`'s configuration (`None` past the last).
    pub(super) fn step(&self, a: &Axis, i: u8) -> Option<Step> {
        let n = a.node.get() as u32;
        let w = |index, sub, v, len| Step::Write(Object::new(index, sub), word(v, len));
        let period_us = (self.period.as_nanos() / 1000).max(1);
        // 0x60C2: value × 10^index s, value a u8.
        let (ip_value, ip_index) = if period_us.is_multiple_of(1000) && period_us / 1000 <= 255 {
            ((period_us / 1000) as u32, -3i8)
        } else {
            ((period_us / 100).clamp(1, 255) as u32, -4i8)
        };
        Some(match i {
            0 => Step::Read(Object::new(0x1000, 0), Check::DeviceProfile402),
            1 => Step::Read(Object::new(0x1008, 0), Check::Name),
            2 => Step::Read(Object::new(cia402::RATED_TORQUE, 0), Check::RatedTorque),
            // RPDO1: controlword, target position, torque offset.
            3 => w(0x1400, 1, 0x8000_0200 + n, 4),
            4 => w(0x1400, 2, 1, 1),
            5 => w(0x1600, 0, 0, 1),
            6 => w(0x1600, 1, cia402::CSP_RPDO1[0], 4),
            7 => w(0x1600, 2, cia402::CSP_RPDO1[1], 4),
            8 => w(0x1600, 3, cia402::CSP_RPDO1[2], 4),
            9 => w(0x1600, 0, 3, 1),
            10 => w(0x1400, 1, 0x200 + n, 4),
            // TPDO1: statusword, position actual, torque actual, every SYNC.
            11 => w(0x1800, 1, 0x8000_0180 + n, 4),
            12 => w(0x1800, 2, 1, 1),
            13 => w(0x1A00, 0, 0, 1),
            14 => w(0x1A00, 1, cia402::CSP_TPDO1[0], 4),
            15 => w(0x1A00, 2, cia402::CSP_TPDO1[1], 4),
            16 => w(0x1A00, 3, cia402::CSP_TPDO1[2], 4),
            17 => w(0x1A00, 0, 3, 1),
            18 => w(0x1800, 1, 0x180 + n, 4),
            19 => w(cia402::COMMUNICATION_CYCLE_PERIOD, 0, period_us as u32, 4),
            20 => w(cia402::INTERPOLATION_TIME_PERIOD, 1, ip_value, 1),
            21 => w(
                cia402::INTERPOLATION_TIME_PERIOD,
                2,
                ip_index as u8 as u32,
                1,
            ),
            22 => w(
                cia402::MODES_OF_OPERATION,
                0,
                cia402::MODE_CSP as u8 as u32,
                1,
            ),
            23 => Step::Read(
                Object::new(cia402::MODES_OF_OPERATION_DISPLAY, 0),
                Check::ModeCsp,
            ),
            24 => w(cia402::HEARTBEAT_PRODUCER, 0, HEARTBEAT_MS as u32, 2),
            25 => w(
                cia402::HEARTBEAT_CONSUMER,
                1,
                (self.master.get() as u32) << 16 | self.consumer_ms as u32,
                4,
            ),
            26 => Step::Start,
            _ => return None,
        })
    }

    /// Sends what each configuring drive needs next, and times out
    /// unanswered transfers.
    pub(super) fn configure(&mut self, now: Nanos, out: &mut Out<'_>) {
        for j in 0..self.set.joints.len() {
            for ax in 0..2 {
                let a = self.set.joints[j][ax];
                let Setup::Step {
                    step,
                    sent,
                    attempts,
                    segment,
                } = a.setup
                else {
                    continue;
                };
                let Some(s) = self.step(&a, step) else {
                    continue;
                };
                let object = match s {
                    Step::Read(o, _) | Step::Write(o, _) => o,
                    Step::Start => Object::new(0, 0),
                };
                if let Some(t) = sent {
                    if now.saturating_sub(t) < self.sdo_timeout {
                        continue;
                    }
                    if attempts >= SDO_ATTEMPTS {
                        // Tell the drive the transfer is over.
                        Self::send(
                            out,
                            Message::SdoRequest {
                                node: a.node,
                                sdo: SdoRequest::Abort {
                                    object,
                                    code: AbortCode::Timeout,
                                },
                            },
                        );
                        self.set.joints[j][ax].setup =
                            Setup::Failed(step, ConfigFailure::Timeout(object));
                        self.untold |= 1 << (2 * j + ax);
                        continue;
                    }
                }
                let node = a.node;
                let m = match (s, segment) {
                    (Step::Read(..), Some(toggle)) => Message::SdoRequest {
                        node,
                        sdo: SdoRequest::UploadSegment { toggle },
                    },
                    (Step::Read(o, _), None) => Message::SdoRequest {
                        node,
                        sdo: SdoRequest::Upload { object: o },
                    },
                    (Step::Write(o, data), _) => Message::SdoRequest {
                        node,
                        sdo: SdoRequest::Download { object: o, data },
                    },
                    (Step::Start, _) => {
                        Self::send(
                            out,
                            Message::Nmt {
                                command: NmtCommand::Start,
                                node: Some(node),
                            },
                        );
                        self.set.joints[j][ax].setup = Setup::Done;
                        self.untold |= 1 << (2 * j + ax);
                        continue;
                    }
                };
                // A retried segmented upload starts over.
                let m = match (sent, m) {
                    (
                        Some(_),
                        Message::SdoRequest {
                            sdo: SdoRequest::UploadSegment { .. },
                            ..
                        },
                    ) => {
                        self.set.joints[j][ax].name_len = 0;
                        Message::SdoRequest {
                            node,
                            sdo: SdoRequest::Upload { object },
                        }
                    }
                    (_, m) => m,
                };
                let segment = match m {
                    Message::SdoRequest {
                        sdo: SdoRequest::Upload { .. },
                        ..
                    } => None,
                    _ => segment,
                };
                Self::send(out, m);
                self.set.joints[j][ax].setup = Setup::Step {
                    step,
                    sent: Some(now),
                    attempts: if sent.is_some() { attempts + 1 } else { 1 },
                    segment,
                };
            }
        }
    }

    /// An SDO response from drive `(j, ax)`.
    pub(super) fn sdo_response(&mut self, j: usize, ax: usize, r: SdoResponse) {
        let a = self.set.joints[j][ax];
        let Setup::Step { step, segment, .. } = a.setup else {
            // Not ours (another client's, or late): ignored.
            self.set.counters.foreign_commands += 1;
            return;
        };
        let Some(s) = self.step(&a, step) else {
            return;
        };
        let fail = |why| Setup::Failed(step, why);
        let next = Setup::Step {
            step: step + 1,
            sent: None,
            attempts: 0,
            segment: None,
        };
        let axis = &mut self.set.joints[j][ax];
        axis.setup = match (s, r) {
            (Step::Read(o, _) | Step::Write(o, _), SdoResponse::Abort { object, code })
                if object == o =>
            {
                fail(ConfigFailure::Abort { object, code })
            }
            (Step::Write(o, _), SdoResponse::DownloadAck { object }) if object == o => next,
            (Step::Read(o, check), SdoResponse::Upload { object, data }) if object == o => {
                let v = data.as_u32();
                let ok = match check {
                    Check::DeviceProfile402 => v & 0xFFFF == 402,
                    Check::Name => {
                        let b = data.bytes();
                        axis.name[..b.len()].copy_from_slice(b);
                        axis.name_len = b.len() as u8;
                        true
                    }
                    Check::RatedTorque => {
                        axis.rated_mnm = v;
                        v > 0 || axis.map.rated_torque > 0.0
                    }
                    Check::ModeCsp => v as u8 as i8 == cia402::MODE_CSP,
                };
                if ok {
                    next
                } else {
                    fail(ConfigFailure::Unexpected { object, value: v })
                }
            }
            (Step::Read(o, Check::Name), SdoResponse::UploadSegmented { object, .. })
                if object == o && segment.is_none() =>
            {
                axis.name_len = 0;
                Setup::Step {
                    step,
                    sent: None,
                    attempts: 0,
                    segment: Some(false),
                }
            }
            (Step::Read(_, Check::Name), SdoResponse::UploadSegment { toggle, data, last })
                if segment == Some(toggle) =>
            {
                let have = axis.name_len as usize;
                let take = data.bytes().len().min(NAME_LEN - have);
                axis.name[have..have + take].copy_from_slice(&data.bytes()[..take]);
                axis.name_len = (have + take) as u8;
                if last {
                    next
                } else {
                    Setup::Step {
                        step,
                        sent: None,
                        attempts: 0,
                        segment: Some(!toggle),
                    }
                }
            }
            // An answer that is not the one awaited (a late answer to a
            // request that timed out and was sent again, a stale segment):
            // ignored; the timeout and its retries decide.
            (Step::Read(..) | Step::Write(..), _) => {
                self.set.counters.foreign_commands += 1;
                return;
            }
            (Step::Start, _) => a.setup,
        };
        if matches!(axis.setup, Setup::Failed(..)) {
            self.untold |= 1 << (2 * j + ax);
        }
    }
}
