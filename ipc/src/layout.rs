//! The payloads' layout, field by field, from the compiler's own offsets.

use core::fmt::Write as _;

use crate::command::{
    CommandReply, CommandRequest, FollowBody, HoldBody, SwimBody, SwimHoldBody, WaypointBody,
};
use crate::payload::*;

/// One row of the documented payload layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LayoutRow {
    /// Payload type.
    pub ty: &'static str,
    /// Field name.
    pub field: &'static str,
    /// Byte offset within the type.
    pub offset: usize,
    /// Size in bytes.
    pub size: usize,
    /// C type.
    pub c_type: &'static str,
}

macro_rules! rows {
    ($ty:ty, $name:literal, [$( $f:ident : $c:literal ),* $(,)?]) => {
        [$( LayoutRow {
            ty: $name,
            field: stringify!($f),
            offset: core::mem::offset_of!($ty, $f),
            size: {
                fn size_of_field<T, F>(_: impl Fn(&T) -> &F) -> usize { core::mem::size_of::<F>() }
                size_of_field(|s: &$ty| &s.$f)
            },
            c_type: $c,
        } ),*]
    };
}

/// The layout of every payload, field by field, from the compiler's own
/// offsets: the source of `docs/ipc.md`'s tables.
pub fn layout_table() -> Vec<LayoutRow> {
    let mut v = Vec::new();
    v.extend(rows!(StateSnapshot, "StateSnapshot", [
        layout_version: "uint32_t", joint_count: "uint32_t", sequence: "uint64_t",
        time_ns: "uint64_t", mode: "uint8_t", cause: "uint8_t", feedforward_dropped: "uint8_t",
        reserved: "uint8_t", fault_kinds: "uint32_t", fault_nodes: "uint64_t", holder_lo: "uint64_t",
        holder_hi: "uint64_t",
        predicted_head_speed: "float", predicted_turn_rate: "float",
        gait_target: "GaitSnapshot", gait_actual: "GaitSnapshot", loop_stats: "LoopSnapshot",
        bus: "BusSnapshot", clamped_setpoints: "uint64_t", refused_commands: "uint64_t",
        operator_silent_stops: "uint64_t", socket_estops: "uint64_t",
        records_lost: "uint64_t",
        limits: "LimitsSnapshot", nav: "NavSnapshot", guide: "GuideSnapshot",
        sensors: "SensorEntry[4]",
        joints: "JointSnapshot[32]",
    ]));
    v.extend(rows!(JointSnapshot, "JointSnapshot", [
        commanded_pitch: "float", commanded_yaw: "float", measured_pitch: "float",
        measured_yaw: "float", commanded_pitch_velocity: "float", commanded_yaw_velocity: "float",
        measured_pitch_velocity: "float", measured_yaw_velocity: "float",
        predicted_pitch_torque: "float", predicted_yaw_torque: "float",
        measured_pitch_torque: "float", measured_yaw_torque: "float", node_state: "uint8_t",
        node_alive: "uint8_t", residual_alarm: "uint8_t", reserved: "uint8_t",
        node_errors: "uint32_t", pitch_torque_residual: "float", yaw_torque_residual: "float",
    ]));
    v.extend(rows!(GaitSnapshot, "GaitSnapshot", [
        amplitude: "float", frequency: "float", turn: "float", pitch: "float",
    ]));
    v.extend(rows!(LoopSnapshot, "LoopSnapshot", [
        period_ns: "uint32_t", jitter_p50_ns: "uint32_t", jitter_p99_ns: "uint32_t",
        jitter_max_ns: "uint32_t", compute_p50_ns: "uint32_t", compute_p99_ns: "uint32_t",
        compute_max_ns: "uint32_t", reserved: "uint32_t", periods: "uint64_t", overruns: "uint64_t",
    ]));
    v.extend(rows!(BusSnapshot, "BusSnapshot", [
        tx_frames: "uint64_t", rx_frames: "uint64_t", tx_dropped: "uint64_t",
        malformed: "uint64_t", errors: "uint64_t", rx_overruns: "uint64_t",
        bus_off_count: "uint32_t", state: "uint8_t",
        reserved: "uint8_t[3]",
    ]));
    v.extend(rows!(LimitsSnapshot, "LimitsSnapshot", [
        max_frequency: "float", max_turn: "float", max_pitch: "float",
        command_timeout_ms: "uint32_t", control_release_ms: "uint32_t", daemon_pid: "uint32_t",
    ]));
    v.extend(rows!(SensorEntry, "SensorEntry", [
        kind: "uint8_t", id: "uint8_t", health: "uint8_t", reserved: "uint8_t",
        samples: "uint32_t", values: "float[8]",
    ]));
    v.extend(rows!(NavSnapshot, "NavSnapshot", [
        sensor: "uint8_t", hold: "uint8_t", hold_exit: "uint8_t", roll_alarm: "uint8_t",
        heading_deg: "float", pitch_deg: "float", roll_deg: "float", depth_m: "float",
        depth_rate: "float", temperature: "float", heading_target_deg: "float",
        depth_target_m: "float", rate_innovation: "float", depth_innovation: "float",
        heading_hold: "uint8_t", depth_hold: "uint8_t", surfaced: "uint8_t", reserved: "uint8_t",
        samples: "uint64_t", lost_samples: "uint64_t",
        x_m: "float", y_m: "float", position_sigma_m: "float", position_fixes: "uint32_t",
        current_x: "float", current_y: "float", current_sigma: "float", fix_age_ms: "uint32_t",
        position_health: "uint8_t", reserved_position: "uint8_t[3]",
        speed_scale: "float",
    ]));
    v.extend(rows!(GuideSnapshot, "GuideSnapshot", [
        state: "uint8_t", looped: "uint8_t", leg: "uint16_t", waypoints: "uint16_t",
        reserved: "uint16_t", cross_track_m: "float", along_track_m: "float",
        leg_length_m: "float", heading_deg: "float", integral_m: "float",
        from_x: "float", from_y: "float", to_x: "float", to_y: "float", to_go_m: "float",
    ]));
    v.extend(rows!(CommandRequest, "CommandRequest", [
        layout_version: "uint32_t", code: "uint32_t", sequence: "uint32_t", body: "uint32_t[7]",
    ]));
    v.extend(rows!(SwimBody, "SwimBody", [
        amplitude: "float", frequency: "float", turn: "float", pitch: "float",
    ]));
    v.extend(rows!(HoldBody, "HoldBody", [hold: "uint32_t", heading: "float", depth: "float"]));
    v.extend(rows!(SwimHoldBody, "SwimHoldBody", [
        amplitude: "float", frequency: "float", turn: "float", pitch: "float",
        hold: "uint32_t", heading: "float", depth: "float",
    ]));
    v.extend(rows!(WaypointBody, "WaypointBody", [
        index: "uint32_t", x: "float", y: "float", depth: "float",
    ]));
    v.extend(rows!(FollowBody, "FollowBody", [
        amplitude: "float", frequency: "float", count: "uint32_t", flags: "uint32_t",
    ]));
    v.extend(rows!(CommandReply, "CommandReply", [
        sequence: "uint32_t", accepted: "uint8_t", mode: "uint8_t",
        reason_len: "uint16_t", reason: "char[120]",
    ]));
    v
}

/// Every payload type documented, with its size in bytes.
pub fn payload_sizes() -> [(&'static str, usize); 16] {
    [
        ("StateSnapshot", core::mem::size_of::<StateSnapshot>()),
        ("JointSnapshot", core::mem::size_of::<JointSnapshot>()),
        ("GaitSnapshot", core::mem::size_of::<GaitSnapshot>()),
        ("LoopSnapshot", core::mem::size_of::<LoopSnapshot>()),
        ("BusSnapshot", core::mem::size_of::<BusSnapshot>()),
        ("LimitsSnapshot", core::mem::size_of::<LimitsSnapshot>()),
        ("NavSnapshot", core::mem::size_of::<NavSnapshot>()),
        ("GuideSnapshot", core::mem::size_of::<GuideSnapshot>()),
        ("SensorEntry", core::mem::size_of::<SensorEntry>()),
        ("CommandRequest", core::mem::size_of::<CommandRequest>()),
        ("SwimBody", core::mem::size_of::<SwimBody>()),
        ("HoldBody", core::mem::size_of::<HoldBody>()),
        ("SwimHoldBody", core::mem::size_of::<SwimHoldBody>()),
        ("WaypointBody", core::mem::size_of::<WaypointBody>()),
        ("FollowBody", core::mem::size_of::<FollowBody>()),
        ("CommandReply", core::mem::size_of::<CommandReply>()),
    ]
}

/// The body type of `kind`'s request, by its name in [`layout_table`]:
/// every command answers, so a new one cannot compile without saying.
fn body_type(kind: crate::vocabulary::CommandKind) -> Option<&'static str> {
    use crate::command::Body;
    use crate::vocabulary::CommandKind as K;
    let named = |k: K, name: &'static str| {
        debug_assert_eq!(k, kind);
        Some(name)
    };
    match kind {
        K::Swim => named(SwimBody::KIND, "SwimBody"),
        K::Hold => named(HoldBody::KIND, "HoldBody"),
        K::SwimHold => named(SwimHoldBody::KIND, "SwimHoldBody"),
        K::Waypoint => named(WaypointBody::KIND, "WaypointBody"),
        K::Follow => named(FollowBody::KIND, "FollowBody"),
        K::Enable
        | K::Disable
        | K::Stop
        | K::EStop
        | K::Reset
        | K::TakeControl
        | K::ReleaseControl
        | K::KeepAlive => None,
    }
}

/// The command whose request body `ty` is, if it is one.
fn body_of(ty: &str) -> Option<crate::vocabulary::CommandKind> {
    crate::vocabulary::CommandKind::ALL
        .into_iter()
        .find(|&k| body_type(k) == Some(ty))
}

/// Renders [`layout_table`] as Markdown tables with each type's size.
pub fn layout_markdown() -> String {
    let sizes = payload_sizes();
    let rows = layout_table();
    let mut out = String::new();
    for (ty, size) in sizes {
        let _ = writeln!(out, "### `{ty}` ({size} bytes)\n");
        if let Some(kind) = body_of(ty) {
            let _ = writeln!(
                out,
                "`CommandRequest.body` when `code` is {} ({}); the body's words past its {size} bytes are zero.\n",
                kind.code(),
                kind.name()
            );
        }
        let _ = writeln!(out, "| offset | size | C type | field |");
        let _ = writeln!(out, "|---:|---:|---|---|");
        for r in rows.iter().filter(|r| r.ty == ty) {
            let _ = writeln!(
                out,
                "| {} | {} | `{}` | `{}` |",
                r.offset, r.size, r.c_type, r.field
            );
        }
        out.push('\n');
    }
    out
}

/// docs/ipc.md's sentence on what an E-stop shows, from the code's own
/// tables: the cause and fault bit of an operator's E-stop and of one
/// from the bus ([`FaultKind::cause`]); the daemon's supervisor tests
/// that it shows them (`nodes_obeying_an_operator_estop_are_no_fault`).
///
/// [`FaultKind::cause`]: crate::vocabulary::FaultKind::cause
pub fn estop_markdown() -> String {
    use crate::vocabulary::FaultKind;
    let (op, bus) = (FaultKind::OperatorEStop, FaultKind::BusEStop);
    format!(
        "An operator E-stop shows as cause {} ({}) with fault bits {:#x} ({}) alone: the\n\
         nodes that obey it are not a fault of theirs. An E-stop from the bus (a node's, or\n\
         another sender's frame) shows as cause {} ({}) with {:#x} ({}) and the nodes in\n\
         `fault_nodes`.\n",
        op.cause().code(),
        op.cause().name(),
        op.bit(),
        op.name(),
        bus.cause().code(),
        bus.cause().name(),
        bus.bit(),
        bus.name(),
    )
}

/// The numeric codes of the payloads' enumerations (command codes, modes,
/// causes, fault bits) as Markdown tables: the source of `docs/ipc.md`'s
/// codes section.
pub fn codes_markdown() -> String {
    use crate::vocabulary::{Cause, CommandKind, FaultKind, Mode, SensorHealth, SensorKind};
    let rows = layout_table();
    let mut out = String::new();
    let _ = writeln!(out, "`CommandRequest.code`:\n");
    let _ = writeln!(out, "| code | command | body | needs control |");
    let _ = writeln!(out, "|---:|---|---|---|");
    for k in CommandKind::ALL {
        // The body's fields, from the layout table.
        let body = match body_type(k) {
            Some(ty) => {
                let fields: Vec<_> = rows
                    .iter()
                    .filter(|r| r.ty == ty)
                    .map(|r| r.field)
                    .collect();
                format!("`{ty}`: {}", fields.join(", "))
            }
            None => "none (zero)".into(),
        };
        let control = match k {
            CommandKind::EStop => "**no: never refused**",
            CommandKind::TakeControl => "no (refused while another client holds it)",
            CommandKind::Enable
            | CommandKind::Disable
            | CommandKind::Swim
            | CommandKind::Stop
            | CommandKind::Reset
            | CommandKind::ReleaseControl
            | CommandKind::KeepAlive
            | CommandKind::Hold
            | CommandKind::SwimHold
            | CommandKind::Waypoint
            | CommandKind::Follow => "yes",
        };
        let _ = writeln!(out, "| {} | {} | {body} | {control} |", k.code(), k.name());
    }
    let _ = writeln!(out, "\n`StateSnapshot.mode` and `CommandReply.mode`:\n");
    let _ = writeln!(out, "| code | mode |");
    let _ = writeln!(out, "|---:|---|");
    for m in Mode::ALL {
        let _ = writeln!(out, "| {} | {} |", m as u8, m.name());
    }
    let _ = writeln!(
        out,
        "\n`StateSnapshot.cause` (why the mode last changed):\n"
    );
    let _ = writeln!(out, "| code | cause |");
    let _ = writeln!(out, "|---:|---|");
    for c in Cause::ALL {
        let _ = writeln!(out, "| {} | {} |", c.code(), c.name());
    }
    let _ = writeln!(
        out,
        "\n`StateSnapshot.fault_kinds` (one bit each; latched until reset):\n"
    );
    let _ = writeln!(out, "| bit | value | fault |");
    let _ = writeln!(out, "|---:|---:|---|");
    for k in FaultKind::ALL {
        let v = k as u32;
        let _ = writeln!(out, "| {} | {v:#x} | {} |", v.trailing_zeros(), k.name());
    }
    let _ = writeln!(
        out,
        "\n`NavSnapshot.sensor`, `NavSnapshot.hold_exit` and `SensorEntry.health` (a \
         sensor's health):\n"
    );
    let _ = writeln!(out, "| code | health |");
    let _ = writeln!(out, "|---:|---|");
    for h in SensorHealth::ALL {
        let _ = writeln!(out, "| {} | {} |", h as u8, h.name());
    }
    let _ = writeln!(
        out,
        "\n`NavSnapshot.heading_hold` and `NavSnapshot.depth_hold` (how a held \
         quantity is doing, judged by the daemon every period; 4 and up: the \
         target is not reached):\n"
    );
    let _ = writeln!(out, "| code | hold state |");
    let _ = writeln!(out, "|---:|---|");
    for h in crate::HoldState::ALL {
        let _ = writeln!(out, "| {} | {} |", h as u8, h.name());
    }
    let _ = writeln!(
        out,
        "\n`GuideSnapshot.state` (how a path is doing; 4 and up: it was not \
         finished):\n"
    );
    let _ = writeln!(out, "| code | guide state |");
    let _ = writeln!(out, "|---:|---|");
    for g in crate::GuideState::ALL {
        let _ = writeln!(out, "| {} | {} |", g as u8, g.name());
    }
    let _ = writeln!(
        out,
        "\n`SensorEntry.kind` (0: an empty entry) and what its `values` are, in order:\n"
    );
    let _ = writeln!(out, "| code | kind | values |");
    let _ = writeln!(out, "|---:|---|---|");
    for k in SensorKind::ALL {
        let values: Vec<String> = k
            .values()
            .iter()
            .map(|(name, unit)| format!("{name} ({unit})"))
            .collect();
        let _ = writeln!(
            out,
            "| {} | {} | {} |",
            k as u8,
            k.name(),
            values.join(", ")
        );
    }
    out
}
