//! The simulated robot that `anguilla run` drives when no bus is named: an
//! in-process bus (with CAN wire time at the configured bit rates) and the
//! vertebra nodes on it, on their own thread in real time.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use anguilla_daemon::config::Config;
use anguilla_drivers::Bus;
use anguilla_drivers::mem::MemBus;
use anguilla_protocol::message::{NodeId, Variant};
use anguilla_sim::actuator::ActuatorParams;
use anguilla_sim::node::{NodeConfig, VertebraNode};
use anyhow::Context;

/// The running built-in robot.
pub struct BuiltinSim {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl BuiltinSim {
    /// A short ground-truth summary for the status line (empty: none yet).
    pub fn truth_line(&self) -> String {
        String::new()
    }

    /// Stops the robot's thread.
    pub fn stop(mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Creates the in-process bus and the robot; returns the daemon's end of
/// the bus.
pub fn start_builtin(cfg: &Config) -> anyhow::Result<(Box<dyn Bus>, BuiltinSim)> {
    let mut b = MemBus::builder(&format!("anguilla-builtin-{}", std::process::id()))
        .bitrate(cfg.bus.bitrate)
        .capacity(4096);
    if cfg.bus.fd {
        b = b.data_bitrate(cfg.bus.data_bitrate);
    }
    let bus = b.build();
    let host: Box<dyn Bus> = Box::new(bus.participant());
    let mut port = bus.participant();
    let variant = if cfg.bus.fd {
        Variant::Fd
    } else {
        Variant::Classic
    };
    let clock = std::time::Instant::now();
    let ns = move || clock.elapsed().as_nanos() as u64;
    let mut nodes = cfg
        .node_ids()
        .into_iter()
        .enumerate()
        .map(|(i, id)| {
            Ok(VertebraNode::new(
                NodeConfig {
                    id: NodeId::new(id).map_err(|e| anyhow::anyhow!("{e}"))?,
                    variant,
                    axes: [ActuatorParams::default(); 2],
                    boot_time: 50_000_000,
                    seed: i as u64,
                },
                ns(),
            ))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let thread = std::thread::Builder::new()
        .name("anguilla-sim".into())
        .spawn(move || {
            let mut out = Vec::with_capacity(256);
            while !flag.load(Ordering::Relaxed) {
                // Wait for a frame at most 0.5 ms, then let the nodes live.
                if let Ok(Some(first)) = port.recv(Duration::from_micros(500)) {
                    let now = ns();
                    for n in nodes.iter_mut() {
                        n.receive(now, &first.frame, &mut |f| out.push(f));
                    }
                    let _ = port.drain(&mut |r| {
                        for n in nodes.iter_mut() {
                            n.receive(now, &r.frame, &mut |f| out.push(f));
                        }
                    });
                }
                let now = ns();
                for n in nodes.iter_mut() {
                    n.advance(now, &mut |f| out.push(f));
                }
                for f in out.drain(..) {
                    let _ = port.send(&f);
                }
            }
        })
        .context("starting the simulated robot's thread")?;
    Ok((
        host,
        BuiltinSim {
            stop,
            thread: Some(thread),
        },
    ))
}
