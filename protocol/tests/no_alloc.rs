//! Encoding and decoding allocate nothing: a counting global allocator
//! watches one control period's worth of encode/decode calls.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use anguilla_protocol::message::*;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator, only counting calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: same contract as our caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as our caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn a_period_of_encoding_and_decoding_allocates_nothing() {
    let setpoints = [[AxisSetpoint {
        position: 0.3,
        velocity: 1.0,
        torque: -0.5,
    }; 2]; 12];
    let nodes = NodeSet::first(12);
    let mut decoded = 0usize;
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for variant in [Variant::Classic, Variant::Fd] {
        encode_setpoints(
            variant,
            42,
            anguilla_protocol::message::from_node_one(&setpoints),
            |f| {
                if decode(&f, variant, nodes).is_ok() {
                    decoded += 1;
                }
            },
        )
        .unwrap();
        let sync = Message::Sync { counter: 42 }.encode(variant).unwrap();
        decoded += decode(&sync, variant, nodes).is_ok() as usize;
        for n in 1..=12 {
            let fb = Message::Feedback(Feedback {
                node: NodeId::new(n).unwrap(),
                enabled: true,
                fault: false,
                axes: [AxisFeedback::default(); 2],
            })
            .encode(variant)
            .unwrap();
            decoded += decode(&fb, variant, nodes).is_ok() as usize;
        }
        // Errors are Copy values too.
        let bad = anguilla_protocol::Frame::new_standard(0x7FF, &[]).unwrap();
        assert!(decode(&bad, variant, nodes).is_err());
    }
    let after = ALLOCATIONS.load(Ordering::Relaxed);
    assert_eq!(decoded, 12 + 1 + 12 + 2 + 1 + 12);
    assert_eq!(after - before, 0, "encode/decode allocated");
}
