//! What one client has to send, by class, and the endpoint's round-robin over clients.
//!
//! The core no longer keeps one global queue of built messages that it re-sorts (ACKNACKs rotated to the
//! front, packing keyed on a push counter, oldest-dropped when full, which could be a STATUS or an
//! ACKNACK). Each client has an [`Outbox`]; [`AgentCore::poll_transmit`](super::AgentCore::poll_transmit)
//! takes, in this written order: the ACKNACKs owed (built from the input streams' state when asked), replies
//! outside any session, every client's control messages (stream 0: HEARTBEAT, INFO, TIMESTAMP_REPLY,
//! STATUS, probes), then every client's stream messages (reliable ones, retransmitted or new, built when
//! asked; best-effort ones as delivered), one message per client in turn so that one busy client does not
//! hold the others back.

use std::collections::{HashMap, VecDeque};

use xrce_proto::ClientKey;

/// Control messages a client may have waiting; beyond it the newest are dropped (counted): they are
/// answers and heartbeats the client asks for again.
pub const MAX_CONTROL_QUEUE: usize = 256;

/// The two classes of a client's outgoing messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// Stream 0: control and replies; sent before any client's stream messages.
    Control,
    /// Messages of output streams.
    Stream,
}

/// One client's outgoing messages.
#[derive(Debug, Default)]
pub struct Outbox {
    control: VecDeque<Vec<u8>>,
    stream: VecDeque<Vec<u8>>,
    /// The newest stream message is a best-effort one of this stream that may take more DATA.
    open_best_effort: Option<u8>,
    /// In the endpoint's turn list of control messages, of stream messages.
    listed_control: bool,
    listed_stream: bool,
}

impl Outbox {
    fn queue(&mut self, class: Class) -> &mut VecDeque<Vec<u8>> {
        match class {
            Class::Control => &mut self.control,
            Class::Stream => &mut self.stream,
        }
    }

    /// Queues a message; returns the message dropped to make room (the oldest stream message, or this
    /// control message when the control queue is full).
    pub fn push(&mut self, class: Class, msg: Vec<u8>, max_stream: usize) -> Option<Vec<u8>> {
        match class {
            Class::Control if self.control.len() >= MAX_CONTROL_QUEUE => return Some(msg),
            Class::Control => self.control.push_back(msg),
            Class::Stream => {
                self.open_best_effort = None;
                self.stream.push_back(msg);
                if self.stream.len() > max_stream.max(1) {
                    return self.stream.pop_front();
                }
            }
        }
        None
    }

    /// Marks the newest stream message as a best-effort one of `stream` that more DATA may join.
    pub fn leave_open(&mut self, stream: u8) {
        self.open_best_effort = Some(stream);
    }

    /// The newest stream message, if it is a best-effort one of `stream` still open to more DATA.
    pub fn open_message(&mut self, stream: u8) -> Option<&mut Vec<u8>> {
        if self.open_best_effort == Some(stream) {
            self.stream.back_mut()
        } else {
            None
        }
    }

    /// The next message of `class`.
    pub fn pop(&mut self, class: Class) -> Option<Vec<u8>> {
        let msg = self.queue(class).pop_front();
        if class == Class::Stream && self.stream.is_empty() {
            self.open_best_effort = None;
        }
        msg
    }

    /// Whether messages of `class` wait.
    pub fn has(&self, class: Class) -> bool {
        match class {
            Class::Control => !self.control.is_empty(),
            Class::Stream => !self.stream.is_empty(),
        }
    }

    /// Messages waiting.
    pub fn len(&self) -> usize {
        self.control.len() + self.stream.len()
    }

    /// Whether nothing waits.
    #[cfg(test)]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Drops everything (the client's endpoint went away).
    pub fn clear(&mut self) {
        self.control.clear();
        self.stream.clear();
        self.open_best_effort = None;
    }

    /// Sets whether the client is in the endpoint's turn list of `class`; returns whether it was.
    pub(super) fn set_listed(&mut self, class: Class, listed: bool) -> bool {
        let slot = match class {
            Class::Control => &mut self.listed_control,
            Class::Stream => &mut self.listed_stream,
        };
        std::mem::replace(slot, listed)
    }
}

/// The clients with messages of each class waiting, in turn order.
#[derive(Debug, Default)]
pub struct TurnLists {
    control: VecDeque<ClientKey>,
    stream: VecDeque<ClientKey>,
}

impl TurnLists {
    fn list(&mut self, class: Class) -> &mut VecDeque<ClientKey> {
        match class {
            Class::Control => &mut self.control,
            Class::Stream => &mut self.stream,
        }
    }

    /// `key`, whose outbox just got a message of `class`, takes a turn if it has none yet.
    pub fn enlist(&mut self, key: ClientKey, outbox: &mut Outbox, class: Class) {
        if !outbox.set_listed(class, true) {
            self.list(class).push_back(key);
        }
    }

    /// The next client of `clients` whose turn it is for `class`: its address and its message; the client
    /// goes to the back of the list while it has more. `outbox` gives a client's outbox and address; gone
    /// clients are skipped.
    pub fn next<T, A>(
        &mut self,
        class: Class,
        clients: &mut HashMap<ClientKey, T>,
        outbox: impl Fn(&mut T) -> (&mut Outbox, A),
    ) -> Option<(A, Vec<u8>)> {
        while let Some(key) = self.list(class).pop_front() {
            let Some(client) = clients.get_mut(&key) else { continue };
            let (out, address) = outbox(client);
            let Some(msg) = out.pop(class) else {
                out.set_listed(class, false);
                continue;
            };
            if out.has(class) {
                self.list(class).push_back(key);
            } else {
                out.set_listed(class, false);
            }
            return Some((address, msg));
        }
        None
    }

    /// The client whose turn it is for `class`, taken off the list (the caller puts it back with
    /// [`Self::requeue`] while it has more, or unlists it).
    pub fn pop(&mut self, class: Class) -> Option<ClientKey> {
        self.list(class).pop_front()
    }

    /// Puts `key` back at the end of the list of `class` (it keeps its listed flag).
    pub fn requeue(&mut self, class: Class, key: ClientKey) {
        self.list(class).push_back(key);
    }

    /// Forgets every turn.
    pub fn clear(&mut self) {
        self.control.clear();
        self.stream.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn itself(o: &mut Outbox) -> (&mut Outbox, ()) {
        (o, ())
    }

    #[test]
    fn control_never_waits_behind_stream_messages_and_clients_take_turns() {
        let (a, b) = (ClientKey([0, 0, 0, 1]), ClientKey([0, 0, 0, 2]));
        let mut boxes: HashMap<ClientKey, Outbox> = HashMap::new();
        let mut turns = TurnLists::default();
        for (key, tag) in [(a, 1u8), (a, 2), (a, 3), (b, 10)] {
            let out = boxes.entry(key).or_default();
            assert_eq!(out.push(Class::Stream, vec![tag], 100), None);
            turns.enlist(key, out, Class::Stream);
        }
        let out = boxes.entry(b).or_default();
        assert_eq!(out.push(Class::Control, vec![99], 100), None);
        turns.enlist(b, out, Class::Control);
        let mut sent = Vec::new();
        for class in [Class::Control, Class::Stream] {
            while let Some((_, msg)) = turns.next(class, &mut boxes, itself) {
                sent.push(msg[0]);
            }
        }
        assert_eq!(sent, vec![99, 1, 10, 2, 3], "control first, then one message per client in turn");
        assert!(boxes.values().all(Outbox::is_empty));
    }

    #[test]
    fn a_full_stream_queue_drops_its_oldest_and_control_is_bounded_apart() {
        let mut out = Outbox::default();
        assert_eq!(out.push(Class::Stream, vec![1], 2), None);
        assert_eq!(out.push(Class::Stream, vec![2], 2), None);
        assert_eq!(out.push(Class::Stream, vec![3], 2), Some(vec![1]));
        for i in 0..MAX_CONTROL_QUEUE {
            assert_eq!(out.push(Class::Control, vec![i as u8], 2), None);
        }
        assert_eq!(out.push(Class::Control, vec![7], 2), Some(vec![7]), "the newest control message is refused");
        assert_eq!(out.pop(Class::Control), Some(vec![0]), "queued control messages are kept");
    }
}
