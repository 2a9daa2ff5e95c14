//! The drive's NMT side (CiA 301): boot-up, the heartbeat it produces,
//! the watchdogs on the master's heartbeat and on SYNC, and the NMT
//! commands (start, stop, pre-operational, the two resets).

use super::Cia402Axis;
use super::{
    EMCY_HEARTBEAT, EMCY_SYNC, ERR_COMMUNICATION, Nmt, S_CONSUMER, S_CYCLE_PERIOD, S_PRODUCER,
    SYNC_TIMEOUT_MIN, Sdo,
};
use crate::node::Nanos;
use anguilla_protocol::canopen::cia402::DriveState;
use anguilla_protocol::canopen::{Message, NmtCommand, NmtState};
use anguilla_protocol::frame::Frame;

impl Cia402Axis {
    pub(super) fn watchdogs(&mut self, t: Nanos, tx: &mut dyn FnMut(Frame)) {
        // Three cycles, but no less than 100 ms (the anguilla node's rule:
        // a master without SCHED_FIFO stalls for tens of milliseconds on a
        // busy machine), nor than the master's heartbeat time the drive
        // consumes (0x1016: a master on a slow host declares a longer one).
        let consumer_ms = (self.od.num(S_CONSUMER) as u32 & 0xFFFF) as u64;
        let sync_timeout = |cycle_us: u64| {
            Nanos::from_nanos(3 * cycle_us * 1000)
                .max(SYNC_TIMEOUT_MIN)
                .max(Nanos::from_millis(consumer_ms))
        };
        let cycle_us = self.od.num(S_CYCLE_PERIOD) as u64;
        if self.drive == DriveState::OperationEnabled
            && cycle_us != 0
            && t.saturating_sub(self.last_sync) > sync_timeout(cycle_us)
        {
            self.counters.watchdog_expiries += 1;
            self.fault(EMCY_SYNC, ERR_COMMUNICATION, tx);
        }
        let consumer = self.od.num(S_CONSUMER) as u32;
        let time = Nanos::from_millis(u64::from(consumer & 0xFFFF));
        if self.nmt == Nmt::Operational
            && time > Nanos::ZERO
            && !self.consumer_expired
            && self
                .consumer_last
                .is_some_and(|last| t.saturating_sub(last) > time)
        {
            self.consumer_expired = true;
            self.counters.watchdog_expiries += 1;
            self.fault(EMCY_HEARTBEAT, ERR_COMMUNICATION, tx);
        }
    }

    pub(super) fn heartbeat(&self, tx: &mut dyn FnMut(Frame)) {
        if let (Some(node), Some(state)) = (self.node, self.nmt_state()) {
            self.send(tx, Message::Heartbeat { node, state });
        }
    }

    /// Boot-up: the boot-up message, pre-operational, the drive from Not
    /// ready to switch on to Switch on disabled (or Fault if a fault
    /// condition persists).
    pub(super) fn boot_up(&mut self, t: Nanos, tx: &mut dyn FnMut(Frame)) {
        let Some(node) = self.node else {
            return;
        };
        self.nmt = Nmt::PreOperational;
        self.send(
            tx,
            Message::Heartbeat {
                node,
                state: NmtState::BootUp,
            },
        );
        let period = Nanos::from_millis(self.od.num(S_PRODUCER) as u64);
        self.next_heartbeat = (period > Nanos::ZERO).then(|| t + period);
        if self.drive == DriveState::NotReadyToSwitchOn {
            self.set_drive(DriveState::SwitchOnDisabled);
        }
        if self.injected != 0 && self.drive != DriveState::Fault {
            self.injected_fault(tx);
        }
        self.refresh_statusword();
    }

    pub(super) fn leave_operational(&mut self) {
        if self.nmt == Nmt::Operational
            && matches!(
                self.drive,
                DriveState::OperationEnabled | DriveState::QuickStopActive
            )
        {
            // Abort connection option code 2: disable voltage.
            self.set_drive(DriveState::SwitchOnDisabled);
        }
        self.rpdo_pending = [None; 2];
        self.sdo = Sdo::Idle;
    }

    pub(super) fn on_nmt(&mut self, command: NmtCommand, now: Nanos, tx: &mut dyn FnMut(Frame)) {
        match command {
            NmtCommand::Start => {
                if matches!(self.nmt, Nmt::PreOperational | Nmt::Stopped) {
                    self.nmt = Nmt::Operational;
                    self.tpdo_count = [0; 2];
                    self.tpdo_last = [None; 2];
                }
            }
            NmtCommand::Stop => {
                self.leave_operational();
                self.nmt = Nmt::Stopped;
            }
            NmtCommand::EnterPreOperational => {
                self.leave_operational();
                self.nmt = Nmt::PreOperational;
            }
            NmtCommand::ResetNode => {
                self.leave_operational();
                self.od.reset(|_| true);
                self.drive = DriveState::NotReadyToSwitchOn;
                self.last_controlword = 0;
                self.reset_communication_state();
                self.nmt = Nmt::Initialising;
                self.boot_at = now + self.boot_time;
                self.refresh_statusword();
            }
            NmtCommand::ResetCommunication => {
                self.leave_operational();
                // The communication parameters; the error register is the
                // drive's status and stays.
                self.od
                    .reset(|i| (0x1000..0x2000).contains(&i) && i != 0x1001);
                self.reset_communication_state();
                self.nmt = Nmt::Initialising;
                self.boot_up(now, tx);
            }
        }
    }

    pub(super) fn reset_communication_state(&mut self) {
        self.sdo = Sdo::Idle;
        self.rpdo_pending = [None; 2];
        self.tpdo_count = [0; 2];
        self.tpdo_last = [None; 2];
        self.next_heartbeat = None;
        self.consumer_last = None;
        self.consumer_expired = false;
    }
}
