//! What the scheduler sends a worker's connection ([`Outgoing`]): a message, or a message
//! encoded once for every worker (a sequence's frame Job, with its scene), which every
//! connection writes from the same bytes instead of holding a copy of the scene each.

use parrt_protocol::{Encoded, Message};

/// One item of a worker's outbox.
#[derive(Clone, Debug, PartialEq)]
pub enum Outgoing {
    /// A message, encoded when written.
    Message(Message),
    /// A message already encoded, shared by every connection it goes to.
    Encoded(Encoded),
}

impl From<Message> for Outgoing {
    fn from(m: Message) -> Self {
        Outgoing::Message(m)
    }
}
