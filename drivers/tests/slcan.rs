//! SLCAN driver behaviour beyond the conformance suite: clear errors for
//! every way opening can fail, garbage on the line, unplugged adapters.

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anguilla_drivers::mem::MemBus;
use anguilla_drivers::slcan::codec::Bitrate;
use anguilla_drivers::slcan::emulator::{EmulatorConfig, SlcanEmulator};
use anguilla_drivers::slcan::{SlcanBus, SlcanConfig};
use anguilla_drivers::{Bus, Frame, LinkError, LostReason, OpenError, open};
use serialport::{SerialPort, TTYPort};

/// Generous bound for a condition on a loaded machine, stretched by
/// `ANGUILLA_TEST_PATIENCE` (anguilla_testkit); never a speed claim.
fn patience() -> Duration {
    anguilla_testkit::patient(Duration::from_secs(5))
}

/// Runs `f` on a thread; fails if it takes more than 60 s (times the
/// patience).
fn watchdog<F: FnOnce() + Send + 'static>(f: F) {
    let (tx, rx) = std::sync::mpsc::channel();
    let t = std::thread::spawn(move || {
        f();
        let _ = tx.send(());
    });
    match rx.recv_timeout(anguilla_testkit::patient(Duration::from_secs(60))) {
        Ok(()) | Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
            if let Err(p) = t.join() {
                std::panic::resume_unwind(p)
            }
        }
        Err(_) => panic!("watchdog expired"),
    }
}

fn emulator(config: EmulatorConfig) -> (MemBus, SlcanEmulator) {
    let bus = MemBus::builder("slcan-test").build();
    let emu = SlcanEmulator::on_pty(Box::new(bus.participant()), config).unwrap();
    (bus, emu)
}

#[test]
fn missing_device_is_named() {
    let spec = "slcan:/dev/anguilla-no-such-tty@1000000";
    let e = open(spec).err().unwrap();
    assert!(matches!(e, OpenError::MissingDevice { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(
        msg.contains("/dev/anguilla-no-such-tty") && msg.contains(spec),
        "{msg}"
    );
}

/// Runs `f` on a thread of its own whose effective capabilities are none:
/// Linux keeps capabilities per thread, so root's bypass of file modes
/// (CAP_DAC_OVERRIDE) is gone for that thread alone and a mode is enforced
/// for root as for anyone. A no-op for other users (no capabilities).
fn without_capabilities<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::spawn(move || {
        #[repr(C)]
        struct Header {
            version: u32,
            pid: libc::c_int,
        }
        #[repr(C)]
        #[derive(Clone, Copy, Default)]
        struct Data {
            effective: u32,
            permitted: u32,
            inheritable: u32,
        }
        let mut header = Header {
            version: 0x2008_0522, // _LINUX_CAPABILITY_VERSION_3
            pid: 0,
        };
        let mut data = [Data::default(); 2];
        // SAFETY: capget with a version-3 header and its two data words.
        let r = unsafe { libc::syscall(libc::SYS_capget, &mut header, data.as_mut_ptr()) };
        assert_eq!(r, 0, "capget: {}", std::io::Error::last_os_error());
        for d in &mut data {
            d.effective = 0;
        }
        // SAFETY: as above; lowering this thread's effective set.
        let r = unsafe { libc::syscall(libc::SYS_capset, &mut header, data.as_ptr()) };
        assert_eq!(r, 0, "capset: {}", std::io::Error::last_os_error());
        f()
    })
    .join()
    .unwrap()
}

/// A device that this user may not open is named, as root too (before,
/// the test returned early as root, CI's user, and reported ok).
#[test]
fn permission_denied_is_named() {
    use std::os::unix::fs::PermissionsExt;
    let path = std::env::temp_dir().join(format!("anguilla-noperm-{}", std::process::id()));
    std::fs::write(&path, b"").unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o000)).unwrap();
    let spec = format!("slcan:{}@1000000", path.display());
    let e = without_capabilities({
        let spec = spec.clone();
        move || open(&spec).err()
    });
    let _ = std::fs::remove_file(&path);
    let e = e.expect("a device of mode 000 opened");
    assert!(matches!(e, OpenError::PermissionDenied { .. }), "{e:?}");
    assert!(e.to_string().contains(&spec));
}

#[test]
fn adapter_answering_bel_is_a_clear_error() {
    watchdog(|| {
        let (_bus, emu) = emulator(EmulatorConfig {
            reject_all: true,
            ..EmulatorConfig::default()
        });
        let path = emu.path().unwrap().to_owned();
        let e = open(&format!("slcan:{path}@1000000")).err().unwrap();
        assert!(matches!(e, OpenError::AdapterRejected { .. }), "{e:?}");
        let msg = e.to_string();
        assert!(
            msg.contains(&path) && msg.contains("'S8'") && msg.contains("BEL"),
            "{msg}"
        );
    });
}

#[test]
fn silent_device_times_out_with_a_clear_error() {
    watchdog(|| {
        let (_master, slave) = TTYPort::pair().unwrap();
        let path = slave.name().unwrap();
        let mut c = SlcanConfig::new(&path, Bitrate::B500k);
        c.reply_timeout = Duration::from_millis(100);
        let e = SlcanBus::open(&c).err().unwrap();
        assert!(matches!(e, OpenError::AdapterTimeout { .. }), "{e:?}");
        assert!(e.to_string().contains(&path), "{e}");
    });
}

#[test]
fn garbage_instead_of_an_adapter_is_a_clear_error() {
    watchdog(|| {
        let (mut master, slave) = TTYPort::pair().unwrap();
        master.set_timeout(Duration::from_millis(10)).unwrap();
        let path = slave.name().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        // A GPS receiver, say: NMEA sentences, never SLCAN.
        let gps = std::thread::spawn(move || {
            while !s.load(Ordering::Relaxed) {
                let _ = master.write_all(b"$GPGGA,123519,4807.038,N,01131.000,E*47\r\n");
            }
        });
        let mut c = SlcanConfig::new(&path, Bitrate::B1M);
        c.reply_timeout = Duration::from_millis(200);
        let e = SlcanBus::open(&c).err().unwrap();
        stop.store(true, Ordering::Relaxed);
        gps.join().unwrap();
        assert!(matches!(e, OpenError::AdapterGarbage { .. }), "{e:?}");
        let msg = e.to_string();
        // Whole lines are quoted: the reader keeps its place in the stream.
        assert!(
            msg.contains(&path) && msg.contains("\"$GPGGA,123519"),
            "{msg}"
        );
    });
}

/// Wraps the emulator's side of the line and puts junk before every frame
/// line it writes.
struct Garbling<S>(S);

impl<S: Read> Read for Garbling<S> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(buf)
    }
}

impl<S: Write> Write for Garbling<S> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if buf.first() == Some(&b't') {
            self.0.write_all(b"\x00\xff\x1b[0m!!\rt12\r")?;
        }
        self.0.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

#[test]
fn garbage_between_frames_is_counted_and_skipped() {
    watchdog(|| {
        let bus = MemBus::builder("garbling").build();
        let mut peer = bus.participant();
        let (mut master, slave) = TTYPort::pair().unwrap();
        master.set_timeout(Duration::from_millis(2)).unwrap();
        let emu = SlcanEmulator::spawn(
            Garbling(master),
            Box::new(bus.participant()),
            EmulatorConfig::default(),
        )
        .unwrap();
        let mut c = SlcanConfig::new(&slave.name().unwrap(), Bitrate::B1M);
        c.status_interval = None;
        let mut drv = SlcanBus::open(&c).unwrap();
        for i in 0..5u8 {
            peer.send(&Frame::new_standard(0x50, &[i]).unwrap())
                .unwrap();
        }
        let mut got = Vec::new();
        let t0 = Instant::now();
        while got.len() < 5 {
            assert!(t0.elapsed() < patience(), "got {got:?}");
            if let Some(r) = drv.recv(Duration::from_millis(50)).unwrap() {
                got.push(r.frame.data()[0]);
            }
        }
        assert_eq!(got, vec![0, 1, 2, 3, 4]);
        // Two bad lines before each frame ("\0\xff\x1b[0m!!" and "t12").
        assert!(drv.counters().errors >= 10, "{:?}", drv.counters());
        drop(drv);
        drop(emu);
        drop(slave);
    });
}

#[test]
fn unplugged_adapter_is_reported_as_disconnected() {
    watchdog(|| {
        let (_bus, emu) = emulator(EmulatorConfig::default());
        let spec = format!("slcan:{}@1000000", emu.path().unwrap());
        let mut drv = open(&spec).unwrap();
        drop(emu.stop());
        let t0 = Instant::now();
        loop {
            assert!(t0.elapsed() < patience(), "no disconnection reported");
            match drv.recv(Duration::from_millis(20)) {
                Err(e @ LinkError::Disconnected(reason)) => {
                    // The error owns nothing: the caller names the bus
                    // from `spec()` ("adapter gone: SPEC" in the daemon).
                    assert_eq!(drv.spec(), spec);
                    assert!(
                        matches!(reason, LostReason::EndOfFile | LostReason::Io(_)),
                        "{reason:?}"
                    );
                    assert_eq!(e.to_string(), format!("disconnected ({reason})"));
                    break;
                }
                Ok(_) => {}
                Err(e) => panic!("unexpected {e:?}"),
            }
        }
        // It says so in its state, and keeps answering (no panic).
        assert_eq!(drv.state(), anguilla_drivers::BusState::Gone);
        let _ = drv.recv(Duration::from_millis(1));
        let f = Frame::new_standard(1, &[]).unwrap();
        assert!(drv.send(&f).is_err());
    });
}

#[test]
fn a_replugged_adapter_at_the_same_path_is_reconnected() {
    watchdog(|| {
        // A stable link to the device, as /dev/serial/by-id gives one; the
        // emulated adapter is unplugged (its pty closed) and plugged in
        // again (a new pty behind the same link).
        let link = std::env::temp_dir().join(format!("anguilla-slcan-link-{}", std::process::id()));
        let (bus1, emu1) = emulator(EmulatorConfig::default());
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink(emu1.path().unwrap(), &link).unwrap();
        let mut c = SlcanConfig::new(link.to_str().unwrap(), Bitrate::B1M);
        c.recovery_reply_timeout = Duration::from_millis(500);
        let mut drv = SlcanBus::open(&c).unwrap();
        drop(emu1.stop());
        drop(bus1);
        let t0 = Instant::now();
        while drv.state() != anguilla_drivers::BusState::Gone {
            assert!(t0.elapsed() < patience(), "the unplug went unnoticed");
            let _ = drv.recv(Duration::from_millis(20));
        }
        let reopens = drv.counters().reopens;
        let bus2 = MemBus::builder("slcan-replug").build();
        let mut peer = bus2.participant();
        let emu2 =
            SlcanEmulator::on_pty(Box::new(bus2.participant()), EmulatorConfig::default()).unwrap();
        std::fs::remove_file(&link).unwrap();
        std::os::unix::fs::symlink(emu2.path().unwrap(), &link).unwrap();
        let t0 = Instant::now();
        while drv.state() == anguilla_drivers::BusState::Gone {
            assert!(t0.elapsed() < 2 * patience(), "never reconnected");
            let _ = drv.recv(Duration::from_millis(20));
        }
        assert_eq!(drv.state(), anguilla_drivers::BusState::ErrorActive);
        assert!(drv.counters().reopens > reopens);
        let f = Frame::new_standard(0x42, &[7]).unwrap();
        drv.send(&f).unwrap();
        let t0 = Instant::now();
        loop {
            assert!(
                t0.elapsed() < patience(),
                "nothing reached the new adapter's bus"
            );
            if let Some(r) = peer.recv(Duration::from_millis(50)).unwrap() {
                assert_eq!(r.frame, f);
                break;
            }
        }
        drop(drv);
        drop(emu2.stop());
        let _ = std::fs::remove_file(&link);
    });
}

#[test]
fn recovers_from_bus_off_by_itself_and_never_sends_stale_frames() {
    watchdog(|| {
        let bus = MemBus::builder("auto-recovery").build();
        let mut peer = bus.participant();
        let node = bus.participant();
        let node_id = node.id();
        let emu = SlcanEmulator::on_pty(Box::new(node), EmulatorConfig::default()).unwrap();
        let mut c = SlcanConfig::new(emu.path().unwrap(), Bitrate::B1M);
        c.status_interval = Some(Duration::from_millis(5));
        // This test is about recovery, not speed: be patient with a loaded
        // machine (the default 20 ms could fail an attempt, and the test
        // would then wait for the next one anyway).
        c.recovery_reply_timeout = Duration::from_millis(500);
        let mut drv = SlcanBus::open(&c).unwrap();
        bus.force_state(node_id, anguilla_drivers::BusState::BusOff);
        // Sent while the adapter is off the bus but before the driver
        // knows: the adapter refuses it (BEL); it must never appear later.
        let stale = Frame::new_standard(0x66, &[0xDE]).unwrap();
        let _ = drv.send(&stale);
        let t0 = Instant::now();
        while drv.counters().bus_off_count == 0 || drv.counters().reopens == 0 {
            assert!(t0.elapsed() < patience(), "{:?}", drv.counters());
            let _ = drv.recv(Duration::from_millis(5));
        }
        assert_ne!(drv.state(), anguilla_drivers::BusState::BusOff);
        let fresh = Frame::new_standard(0x67, &[0x01]).unwrap();
        drv.send(&fresh).unwrap();
        let t0 = Instant::now();
        let first = loop {
            assert!(t0.elapsed() < patience(), "fresh frame never arrived");
            if let Some(r) = peer.recv(Duration::from_millis(50)).unwrap() {
                break r.frame;
            }
        };
        assert_eq!(first, fresh, "a frame from before the bus-off came out");
        drop(drv);
        drop(emu);
    });
}

#[test]
fn stop_handle_ends_the_emulator_thread() {
    watchdog(|| {
        let (_bus, emu) = emulator(EmulatorConfig::default());
        assert!(emu.is_running());
        let h = emu.stop_handle();
        std::thread::spawn(move || h.stop()).join().unwrap();
        let t0 = Instant::now();
        while emu.is_running() {
            assert!(t0.elapsed() < patience(), "emulator thread did not stop");
            std::thread::yield_now();
        }
        let _bus_back = emu.stop();
    });
}

#[test]
fn listen_only_refuses_to_send() {
    watchdog(|| {
        let (_bus, emu) = emulator(EmulatorConfig::default());
        let mut drv = open(&format!("slcan:{}@250000?listen=1", emu.path().unwrap())).unwrap();
        let f = Frame::new_standard(1, &[]).unwrap();
        assert!(matches!(drv.send(&f), Err(LinkError::Unsupported(_))));
    });
}

#[test]
fn emulator_answers_version_and_rejects_commands_in_the_wrong_state() {
    watchdog(|| {
        let (_bus, emu) = emulator(EmulatorConfig::default());
        let mut port = serialport::new(emu.path().unwrap(), 115_200)
            .timeout(Duration::from_millis(500))
            .open_native()
            .unwrap();
        let mut ask = |cmd: &[u8], want: &[u8]| {
            port.write_all(cmd).unwrap();
            let mut got = Vec::new();
            let mut b = [0u8; 1];
            while got.len() < want.len() {
                port.read_exact(&mut b).unwrap();
                got.push(b[0]);
            }
            assert_eq!(got, want, "answer to {:?}", cmd.escape_ascii().to_string());
        };
        ask(b"V\r", b"V1013\r");
        ask(b"F\r", b"\x07"); // closed: no status
        ask(b"t1230\r", b"\x07"); // closed: no frames
        ask(b"S9\r", b"\x07"); // no such rate
        ask(b"S6\r", b"\r");
        ask(b"O\r", b"\r");
        ask(b"S8\r", b"\x07"); // open: rate is fixed
        ask(b"F\r", b"F00\r");
        ask(b"t1230\r", b"z\r");
        ask(b"T000001230\r", b"Z\r");
        ask(b"C\r", b"\r");
        ask(b"garbage\r", b"\x07");
    });
}

/// An adapter that stops reading (a starved peer process, a USB adapter
/// whose queue is full): the line's buffer fills, sends are refused as a
/// full queue, and the status poll that cannot be written either is no
/// reason to call the adapter gone. On a loaded machine this was read as
/// "adapter gone" and faulted the daemon.
#[test]
fn an_adapter_that_stops_reading_is_a_full_queue_not_a_lost_adapter() {
    watchdog(|| {
        let (mut master, slave) = TTYPort::pair().unwrap();
        master.set_timeout(Duration::from_millis(50)).unwrap();
        let path = slave.name().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        // Answers the setup commands, then reads nothing more.
        let adapter = std::thread::spawn(move || {
            let mut line = Vec::new();
            let mut opened = false;
            while !opened && !s.load(Ordering::Relaxed) {
                let mut b = [0u8; 64];
                let Ok(n) = master.read(&mut b) else { continue };
                for &c in &b[..n] {
                    if c != b'\r' {
                        line.push(c);
                        continue;
                    }
                    let reply: &[u8] = match line.first() {
                        Some(b'V') => b"V1013\r",
                        _ => b"\r",
                    };
                    opened |= line.first() == Some(&b'O');
                    let _ = master.write_all(reply);
                    line.clear();
                }
            }
            while !s.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(10));
            }
            drop(master);
        });
        let mut c = SlcanConfig::new(&path, Bitrate::B1M);
        c.reply_timeout = Duration::from_secs(2);
        let mut drv = SlcanBus::open(&c).unwrap();
        let f = Frame::new_standard(0x123, &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap();
        let mut sent = 0u32;
        loop {
            match drv.send(&f) {
                Ok(()) => sent += 1,
                Err(LinkError::TxQueueFull) => break,
                Err(e) => panic!("after {sent} frames: {e:?}"),
            }
            assert!(sent < 1_000_000, "the line never filled");
        }
        // Past the status interval: the poll is due and cannot be written.
        let t0 = Instant::now();
        while t0.elapsed() < 3 * c.status_interval.unwrap() {
            match drv.recv(Duration::from_millis(20)) {
                Ok(_) => {}
                Err(e) => panic!("a full line read as {e:?}"),
            }
        }
        assert_ne!(drv.state(), anguilla_drivers::BusState::Gone);
        assert!(matches!(drv.send(&f), Err(LinkError::TxQueueFull)));
        stop.store(true, Ordering::Relaxed);
        adapter.join().unwrap();
    });
}
