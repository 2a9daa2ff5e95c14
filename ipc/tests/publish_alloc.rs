//! Whether publishing the state allocates once the listeners are steady:
//! measured, because it decides whether the control loop may publish
//! itself (it may not allocate; see docs/performance.md).

use std::time::Duration;

use anguilla_ipc::service::StatePublisher;
use anguilla_ipc::{Client, StateSnapshot};

#[global_allocator]
static GLOBAL: anguilla_testkit::CountingAlloc = anguilla_testkit::CountingAlloc;

#[test]
fn steady_state_publication_allocations_are_counted() {
    let prefix = format!("anguilla-publish-alloc/{}", std::process::id());
    let publisher = StatePublisher::new(&prefix).expect("publisher");
    // A client opens the command side too: a server stands by.
    let _server = anguilla_ipc::service::CommandServer::new(&prefix).expect("server");
    let client = Client::new(&prefix, "alloc-probe").expect("client");
    let mut snap = StateSnapshot::default();
    // Warm up: the listener set is read, the segment is touched.
    for _ in 0..10 {
        publisher.publish(&snap).expect("publish");
        let _ = client.wait_state(Duration::from_millis(10));
    }
    let ((), calls) = anguilla_testkit::count(|| {
        for i in 0..100 {
            snap.sequence = i;
            publisher.publish(&snap).expect("publish");
        }
    });
    println!("publish: {calls} allocator calls per 100 publications");
    // iceoryx2 0.10 makes an `Arc` per loaned sample: two calls (alloc and
    // free) per publication. The day this fails, publishing no longer
    // allocates, and the control loop may publish the state itself
    // instead of handing it to the state thread (docs/performance.md).
    assert!(
        calls >= 100,
        "publishing the state made {calls} allocator calls in 100 publications: \
         the loop could now publish it without the state thread's hand-off"
    );
}
