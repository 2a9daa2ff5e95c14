//! Node ids (1..=63) and sets of them.

use super::error::EncodeError;

/// Largest node id the identifier scheme carries (six bits; 0 is broadcast).
pub const MAX_NODE_ID: u8 = 63;

/// A node (vertebra actuator) id, 1..=63.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct NodeId(pub(super) u8);

impl NodeId {
    /// A node id, checked to be in 1..=63.
    pub const fn new(id: u8) -> Result<Self, EncodeError> {
        if id == 0 || id > MAX_NODE_ID {
            Err(EncodeError::BadNodeId(id))
        } else {
            Ok(NodeId(id))
        }
    }

    /// The raw id.
    pub const fn get(self) -> u8 {
        self.0
    }
}

/// The set of node ids a decoder accepts; others are
/// [`DecodeError::UnknownNode`](super::DecodeError::UnknownNode).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct NodeSet(u64);

impl NodeSet {
    /// No nodes.
    pub const fn empty() -> Self {
        NodeSet(0)
    }

    /// Every id 1..=63.
    pub const fn all() -> Self {
        NodeSet(!1u64)
    }

    /// Ids 1..=n (n clamped to 63): a robot of n vertebrae numbered from 1.
    pub const fn first(n: u8) -> Self {
        let n = if n > MAX_NODE_ID { MAX_NODE_ID } else { n };
        NodeSet(((1u128 << (n as u32 + 1)) - 2) as u64)
    }

    /// The same set with `id` added.
    pub const fn with(self, id: NodeId) -> Self {
        NodeSet(self.0 | (1 << id.0))
    }

    /// The set as bits by node id (bit `n` for node `n`), as published in
    /// the operator interface's fault masks.
    pub const fn bits(self) -> u64 {
        self.0
    }

    /// The nodes in `self` or in `other`.
    pub const fn union(self, other: NodeSet) -> Self {
        NodeSet(self.0 | other.0)
    }

    /// The nodes in `self` and not in `other`.
    pub const fn without(self, other: NodeSet) -> Self {
        NodeSet(self.0 & !other.0)
    }

    /// Whether every node of `other` is in `self`.
    pub const fn covers(self, other: NodeSet) -> bool {
        other.0 & !self.0 == 0
    }

    /// Whether `id` (raw) is in the set.
    pub const fn contains(self, id: u8) -> bool {
        id < 64 && (self.0 >> id) & 1 == 1
    }

    /// The set of the given ids.
    pub fn of(ids: impl IntoIterator<Item = NodeId>) -> Self {
        ids.into_iter().fold(Self::empty(), Self::with)
    }

    /// How many ids the set holds.
    pub const fn len(self) -> usize {
        self.0.count_ones() as usize
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The ids, ascending.
    pub fn iter(self) -> impl Iterator<Item = NodeId> {
        (1..=MAX_NODE_ID)
            .filter(move |&i| self.contains(i))
            .map(NodeId)
    }
}
