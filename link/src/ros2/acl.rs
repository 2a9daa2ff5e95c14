//! The ROS 2 node's part of the link router's access list
//! (`bridge::access_control`): rmw_zenoh's nodes ask for and watch the
//! liveliness tokens of the domain; they subscribe to this node's topics,
//! by their data keys; they drive through `cmd_vel`, `path`, the position
//! fixes and the services when the allowlist lets them. Nothing else.

use anguilla_ipc::vocabulary::Command;

use super::graph::{NodeId, qualified};
use super::msgs;
use super::node::{
    CMD_VEL, LATCHED, PATH_SERVICES, POSE_TOPICS, Ros2Settings, SERVICES, TOPICS, service_name,
};

/// Adds the node's rules through `rule(id, message, flow, key)`.
pub(crate) fn rules(r: &Ros2Settings, rule: &mut dyn FnMut(&str, &str, &str, String)) {
    // The ROS 2 graph: rmw_zenoh's nodes ask for and watch the
    // liveliness tokens of the domain; they subscribe to this node's
    // topics, by their data keys; they drive through cmd_vel and the
    // services when the allowlist lets them. Nothing else.
    //
    // The tokens they declare themselves do not enter: the router
    // would keep every one for as long as the client stays (an
    // admitted client declared 10,000: +49 MB, graph queries timed
    // out), and nobody here needs them: this node reads no graph, and
    // the list lets no ROS 2 traffic pass from one client to another.
    // So a client's graph costs the link nothing: docs/ros2.md,
    // "Security".
    let graph = format!("@ros2_lv/{}/**", r.domain);
    for (id, msg, flow) in [
        ("ros2-graph-query", "liveliness_query", "ingress"),
        (
            "ros2-graph-watch",
            "declare_liveliness_subscriber",
            "ingress",
        ),
        ("ros2-graph-tokens-out", "liveliness_token", "egress"),
        ("ros2-graph-reply", "reply", "egress"),
    ] {
        rule(id, msg, flow, graph.clone());
    }
    let node = NodeId {
        domain: r.domain,
        session: String::new(),
        node: 0,
        namespace: r.namespace.clone(),
        name: r.node.clone(),
        humble: r.humble,
    };
    for (i, (name, ty)) in TOPICS.iter().enumerate() {
        let key = node.data_key(&qualified(&r.namespace, name), ty);
        rule(
            &format!("ros2-topic-{i}-subscribe"),
            "declare_subscriber",
            "ingress",
            key.clone(),
        );
        rule(&format!("ros2-topic-{i}-put"), "put", "egress", key);
    }
    // The transient-local topics: their data keys, and their
    // publishers' caches and liveliness under `<key>/@adv/`, which a
    // late subscriber (rmw_zenoh's, an advanced subscriber) asks.
    for (name, ty) in LATCHED {
        let key = node.data_key(&qualified(&r.namespace, name), &ty);
        rule(
            &format!("ros2-{name}-subscribe"),
            "declare_subscriber",
            "ingress",
            key.clone(),
        );
        rule(&format!("ros2-{name}-put"), "put", "egress", key.clone());
        // the cache replies with its samples on their own key
        rule(
            &format!("ros2-{name}-cached"),
            "reply",
            "egress",
            key.clone(),
        );
        let adv = format!("{key}/@adv/**");
        for (id, msg, flow) in [
            ("cache-query", "query", "ingress"),
            ("cache-reply", "reply", "egress"),
            ("heartbeat", "put", "egress"),
            ("heartbeat-subscribe", "declare_subscriber", "ingress"),
            ("detect-query", "liveliness_query", "ingress"),
            ("detect-watch", "declare_liveliness_subscriber", "ingress"),
            // (a late subscriber's detection token, `@adv/sub/`, is
            // for publishers that watch them: this one does not)
            ("detect-token-out", "liveliness_token", "egress"),
        ] {
            rule(&format!("ros2-{name}-{id}"), msg, flow, adv.clone());
        }
    }
    if r.allow_command {
        for (i, ty) in CMD_VEL.iter().enumerate() {
            let key = node.data_key(&qualified(&r.namespace, "cmd_vel"), ty);
            rule(
                &format!("ros2-cmd-vel-{i}-put"),
                "put",
                "ingress",
                key.clone(),
            );
            rule(
                &format!("ros2-cmd-vel-{i}-declare"),
                "declare_subscriber",
                "egress",
                key,
            );
        }
        let key = node.data_key(&qualified(&r.namespace, "path"), &msgs::PATH);
        rule("ros2-path-put", "put", "ingress", key.clone());
        rule("ros2-path-declare", "declare_subscriber", "egress", key);
        if r.pose.is_some() {
            for (topic, ty) in POSE_TOPICS {
                let key = node.data_key(&qualified(&r.namespace, topic), &ty);
                rule(&format!("ros2-{topic}-put"), "put", "ingress", key.clone());
                rule(
                    &format!("ros2-{topic}-declare"),
                    "declare_subscriber",
                    "egress",
                    key,
                );
            }
        }
    }
    let path_services = PATH_SERVICES.map(|n| (n, Command::KeepAlive));
    for (name, cmd) in SERVICES.into_iter().chain(path_services) {
        if !(if cmd == Command::EStop {
            r.allow_estop
        } else {
            r.allow_command
        }) {
            continue;
        }
        let key = node.data_key(&service_name(&r.namespace, &r.node, name), &msgs::TRIGGER);
        rule(
            &format!("ros2-{name}-query"),
            "query",
            "ingress",
            key.clone(),
        );
        rule(
            &format!("ros2-{name}-reply"),
            "reply",
            "egress",
            key.clone(),
        );
        rule(
            &format!("ros2-{name}-declare"),
            "declare_queryable",
            "egress",
            key,
        );
    }
}
