//! A client process that dies while holding control loses it: the daemon's
//! reaper sees its iceoryx2 node dead and releases control. The timeouts are
//! set far longer than the test, so only the reaper can release it.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anguilla_daemon::config::Config;
use anguilla_daemon::run;
use anguilla_drivers::mem::MemBus;
use anguilla_ipc::Client;
use anguilla_ipc::vocabulary::Command;

const CHILD_ENV: &str = "ANGUILLA_TEST_CHILD_PREFIX";

/// Runs only as the child: take control, then die without cleaning up.
#[test]
fn child_client_takes_control_then_crashes() {
    let Ok(prefix) = std::env::var(CHILD_ENV) else {
        return; // not the child: nothing to do in the parent's run
    };
    let mut c = Client::new(&prefix, "crashing-client").expect("client");
    // The parent learns who the child is from its output.
    println!("child client {:032x}", c.id());
    let r = c
        .request(Command::TakeControl, Duration::from_secs(10))
        .expect("reply");
    assert_eq!(r.accepted, 1, "{}", r.reason());
    println!("child took control");
    std::process::abort();
}

#[test]
fn a_dead_holder_loses_control() {
    if std::env::var(CHILD_ENV).is_ok() {
        return;
    }
    let prefix = format!("anguilla-test/crash-{}", std::process::id());
    let mut cfg = Config::default();
    cfg.ipc.prefix = prefix.clone();
    cfg.control.command_timeout = 10.0;
    cfg.control.control_release_timeout = 600.0;
    let bus = MemBus::builder("crashed-client").build();
    let stop = Arc::new(AtomicBool::new(false));
    let running = run::spawn(cfg, Box::new(bus.participant()), stop).expect("daemon");
    let child = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "child_client_takes_control_then_crashes",
            "--nocapture",
        ])
        .env(CHILD_ENV, &prefix)
        .output()
        .expect("child runs");
    assert!(!child.status.success(), "the child aborts");
    let out = String::from_utf8_lossy(&child.stdout);
    // The daemon accepted the child's TakeControl (it says so only after
    // the reply), then the child died holding it.
    assert!(
        out.contains("child took control"),
        "the child held control: {out}"
    );
    // Control is free again only if the reaper released it (the timeouts
    // are far longer than the test): another client takes it. A state, not
    // a moment: a watcher starved by a busy machine could miss the short
    // hold in the published states, but not this.
    let mut watcher = Client::new(&prefix, "watcher").unwrap();
    let deadline = anguilla_testkit::Deadline::new(Duration::from_secs(30));
    let mut released = false;
    let mut last = String::new();
    while !deadline.passed() {
        match watcher.request(Command::TakeControl, Duration::from_secs(5)) {
            Ok(r) if r.accepted == 1 => {
                released = true;
                break;
            }
            Ok(r) => last = r.reason().to_string(),
            Err(e) => last = e.to_string(),
        }
        let _ = watcher.wait_state(Duration::from_millis(100));
    }
    running.request_stop();
    running.join().unwrap();
    assert!(
        released,
        "control released after the holder died (last refusal: {last})"
    );
}
