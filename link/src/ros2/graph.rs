//! rmw_zenoh's graph and wire conventions (rmw_zenoh `docs/design.md`,
//! Jazzy): what makes a plain Zenoh session a ROS 2 node to every other
//! node. Pure text and bytes; [`super::node`] declares them.
//!
//! - **Liveliness tokens**, one per node and per endpoint:
//!   `@ros2_lv/<domain>/<session id>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node name>`,
//!   and for a topic or service `/<name>/<type>/<type hash>/<qos>`, where
//!   `kind` is `NN` (node), `MP` (publisher), `MS` (subscription), `SS`
//!   (service server) or `SC` (service client), and every name has its
//!   `/` written `%` (an empty one is `%`).
//! - **Data keys**: `<domain>/<name without its leading />/<type>/<type hash>`,
//!   the type as `pkg::msg::dds_::Type_`.
//! - **Attachments** on every sample: the publisher's sequence number
//!   (i64), its source timestamp (ns, i64) and its 16-byte GID, in Zenoh's
//!   serialisation (33 bytes).

use super::msgs::MsgType;

/// An endpoint's kind, as a token names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A node.
    Node,
    /// A publisher.
    Publisher,
    /// A subscription.
    Subscription,
    /// A service server.
    Service,
}

impl Kind {
    fn code(self) -> &'static str {
        match self {
            Self::Node => "NN",
            Self::Publisher => "MP",
            Self::Subscription => "MS",
            Self::Service => "SS",
        }
    }
}

/// A topic's or service's quality of service, as rmw_zenoh writes it in a
/// token: `reliability:durability:history,depth:deadline:lifespan:liveliness`
/// with ROS 2's enum values (reliable 1, best effort 2; transient local 1,
/// volatile 2; keep last 1) and an empty field for the default.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Best effort rather than reliable.
    pub best_effort: bool,
    /// Transient local (late joiners get the last `depth` samples).
    pub transient_local: bool,
    /// Keep-last depth.
    pub depth: u32,
}

impl Qos {
    /// Reliable, volatile, keep last `depth`.
    pub const fn reliable(depth: u32) -> Self {
        Self {
            best_effort: false,
            transient_local: false,
            depth,
        }
    }

    /// The token's text.
    pub fn token(&self) -> String {
        format!(
            "{}:{}:,{}:,:,:,,",
            if self.best_effort { "2" } else { "" },
            if self.transient_local { "1" } else { "" },
            self.depth
        )
    }
}

/// `/` as `%` (rmw_zenoh's mangling of names in tokens); `%` for empty.
pub fn mangle(name: &str) -> String {
    if name.is_empty() {
        "%".to_string()
    } else {
        name.replace('/', "%")
    }
}

/// A name under `namespace` (`/` or `/robot`): `/namespace/name`.
pub fn qualified(namespace: &str, name: &str) -> String {
    let ns = namespace.trim_end_matches('/');
    format!("{ns}/{}", name.trim_start_matches('/'))
}

/// Where a node is on the graph.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeId {
    /// `ROS_DOMAIN_ID`.
    pub domain: u32,
    /// The Zenoh session's id, as Zenoh prints it (hex).
    pub session: String,
    /// This node's number in the session.
    pub node: u32,
    /// `/` or `/something`.
    pub namespace: String,
    /// The node's name (no `/`).
    pub name: String,
    /// Humble's rmw_zenoh: `TypeHashNotSupported` where Jazzy's has the
    /// type's hash.
    pub humble: bool,
}

/// What Humble's rmw_zenoh puts where a type hash goes.
pub const NO_TYPE_HASH: &str = "TypeHashNotSupported";

impl NodeId {
    /// The type hash as this node's distribution writes it.
    pub fn hash<'a>(&self, ty: &'a MsgType) -> &'a str {
        if self.humble { NO_TYPE_HASH } else { ty.hash }
    }

    fn prefix(&self, entity: u32, kind: Kind) -> String {
        format!(
            "@ros2_lv/{}/{}/{}/{}/{}/%/{}/{}",
            self.domain,
            self.session,
            self.node,
            entity,
            kind.code(),
            mangle(if self.namespace == "/" {
                ""
            } else {
                &self.namespace
            }),
            self.name
        )
    }

    /// The node's own token (its entity id is its node id).
    pub fn node_token(&self) -> String {
        self.prefix(self.node, Kind::Node)
    }

    /// A publisher's, subscription's or service's token; `name` is fully
    /// qualified (`/joint_states`).
    pub fn token(&self, entity: u32, kind: Kind, name: &str, ty: &MsgType, qos: &Qos) -> String {
        format!(
            "{}/{}/{}/{}/{}",
            self.prefix(entity, kind),
            mangle(name),
            ty.dds_name(),
            self.hash(ty),
            qos.token()
        )
    }

    /// The key samples of `name` (fully qualified) travel on.
    pub fn data_key(&self, name: &str, ty: &MsgType) -> String {
        format!(
            "{}/{}/{}/{}",
            self.domain,
            name.trim_start_matches('/'),
            ty.dds_name(),
            self.hash(ty)
        )
    }
}

/// A sample's attachment: sequence number, source timestamp (ns since the
/// epoch) and the publisher's GID, as Zenoh's serializer writes an
/// `(i64, i64, [u8; 16])`: two little-endian i64, then the array's length
/// (a LEB128 varint, 16) and its bytes.
pub fn attachment(sequence: i64, timestamp_ns: i64, gid: &[u8; 16]) -> [u8; 33] {
    let mut a = [0u8; 33];
    a[..8].copy_from_slice(&sequence.to_le_bytes());
    a[8..16].copy_from_slice(&timestamp_ns.to_le_bytes());
    a[16] = 16;
    a[17..].copy_from_slice(gid);
    a
}

/// Reads an [`attachment`]: `None` unless it is one.
pub fn read_attachment(a: &[u8]) -> Option<(i64, i64, [u8; 16])> {
    let (seq, rest) = a.split_first_chunk::<8>()?;
    let (ts, rest) = rest.split_first_chunk::<8>()?;
    let (&[16], gid) = rest.split_first_chunk::<1>()? else {
        return None;
    };
    let gid: [u8; 16] = gid.try_into().ok()?;
    Some((i64::from_le_bytes(*seq), i64::from_le_bytes(*ts), gid))
}

#[cfg(test)]
mod tests {
    use super::super::msgs;
    use super::*;

    fn node() -> NodeId {
        NodeId {
            domain: 0,
            session: "aac3178e146ba6f1fc6e6a4085e77f21".into(),
            node: 0,
            namespace: "/".into(),
            name: "listener".into(),
            humble: false,
        }
    }

    /// rmw_zenoh's design document's own example: a `listener` node's
    /// subscription to `/chatter` (std_msgs/msg/String, default QoS).
    #[test]
    fn tokens_and_keys_match_rmw_zenohs_example() {
        let n = node();
        assert_eq!(
            n.node_token(),
            "@ros2_lv/0/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"
        );
        assert_eq!(
            n.token(
                10,
                Kind::Subscription,
                "/chatter",
                &msgs::STRING,
                &Qos::reliable(10)
            ),
            "@ros2_lv/0/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%chatter/\
             std_msgs::msg::dds_::String_/\
             RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,10:,:,:,,"
        );
        assert_eq!(
            n.data_key("/chatter", &msgs::STRING),
            "0/chatter/std_msgs::msg::dds_::String_/\
             RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        let ns = NodeId {
            namespace: "/eel".into(),
            ..node()
        };
        assert!(ns.node_token().ends_with("/NN/%/%eel/listener"));
        assert_eq!(qualified("/eel", "joint_states"), "/eel/joint_states");
        assert_eq!(qualified("/", "joint_states"), "/joint_states");
        let humble = NodeId {
            humble: true,
            ..node()
        };
        assert_eq!(
            humble.data_key("/chatter", &msgs::STRING),
            "0/chatter/std_msgs::msg::dds_::String_/TypeHashNotSupported"
        );
        assert!(
            humble
                .token(
                    10,
                    Kind::Publisher,
                    "/chatter",
                    &msgs::STRING,
                    &Qos::reliable(10)
                )
                .ends_with(
                    "/%chatter/std_msgs::msg::dds_::String_/TypeHashNotSupported/::,10:,:,:,,"
                )
        );
    }

    #[test]
    fn attachments_read_back_and_others_are_refused() {
        let gid = [7u8; 16];
        let a = attachment(42, 1_700_000_000_000_000_000, &gid);
        assert_eq!(
            read_attachment(&a),
            Some((42, 1_700_000_000_000_000_000, gid))
        );
        assert_eq!(read_attachment(&a[..32]), None);
        let mut b = a;
        b[16] = 15;
        assert_eq!(read_attachment(&b), None);
    }
}
