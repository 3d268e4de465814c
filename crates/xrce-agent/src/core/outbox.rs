//! What one client has to send, by class, and the endpoint's round-robin over clients.
//!
//! Each client has an [`Outbox`]; [`AgentCore::poll_transmit`](super::AgentCore::poll_transmit) writes, in
//! this written order, into the shell's buffer: the ACKNACKs owed (built from the input streams' state),
//! replies outside any session, every client's control messages (stream 0: HEARTBEAT and TIMESTAMP_REPLY
//! kept as intents and encoded then, with the stream's latest range and the send time; STATUS, INFO and
//! probes encoded when decided), then every client's stream messages (reliable ones, retransmitted or new,
//! built then; best-effort ones as delivered, packed), one message per client in turn so that one busy client
//! does not hold the others back.

use std::collections::VecDeque;

use xrce_proto::ClientKey;

/// Control messages a client may have waiting; beyond it the newest are dropped (counted): they are
/// answers and heartbeats the client asks for again.
pub const MAX_CONTROL_QUEUE: usize = 256;

/// A control message waiting on stream 0.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Control {
    /// A HEARTBEAT of this reliable output stream, built with its range when sent (none if all is
    /// acknowledged by then).
    Heartbeat(u8),
    /// A TIMESTAMP_REPLY: the client's originate time and when its TIMESTAMP arrived; the transmit time is
    /// read when sent.
    TimestampReply { originate: xrce_proto::Time, received: xrce_proto::Time },
    /// A message encoded when decided (STATUS, INFO, GET_INFO probes, READ data on stream 0).
    Message(Vec<u8>),
}

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
    control: VecDeque<Control>,
    stream: VecDeque<Vec<u8>>,
    /// The newest stream message is a best-effort one of this stream that may take more DATA.
    open_best_effort: Option<u8>,
    /// In the endpoint's turn list of control messages, of stream messages.
    listed_control: bool,
    listed_stream: bool,
}

impl Outbox {
    /// Queues a control message; false (dropped) when the control queue is full. A HEARTBEAT of a stream
    /// whose HEARTBEAT already waits is not queued twice (it is built with the latest range anyway).
    pub fn push_control(&mut self, item: Control) -> Result<(), Control> {
        if self.control.len() >= MAX_CONTROL_QUEUE {
            return Err(item);
        }
        if matches!(item, Control::Heartbeat(_)) && self.control.contains(&item) {
            return Ok(());
        }
        self.control.push_back(item);
        Ok(())
    }

    /// Queues a stream message; returns the oldest, dropped to make room past `max_stream`.
    pub fn push_stream(&mut self, msg: Vec<u8>, max_stream: usize) -> Option<Vec<u8>> {
        self.open_best_effort = None;
        self.stream.push_back(msg);
        if self.stream.len() > max_stream.max(1) {
            return self.stream.pop_front();
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

    /// The next control message.
    pub fn pop_control(&mut self) -> Option<Control> {
        self.control.pop_front()
    }

    /// The next stream message.
    pub fn pop_stream(&mut self) -> Option<Vec<u8>> {
        let msg = self.stream.pop_front();
        if self.stream.is_empty() {
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

    /// Frees the queues' buffers when nothing waits, so an idle client keeps none (called on its idle
    /// turns, never per message: a busy client keeps its buffers).
    pub fn trim(&mut self) {
        if self.control.is_empty() && self.control.capacity() > 0 {
            self.control = VecDeque::new();
        }
        if self.stream.is_empty() && self.stream.capacity() > 0 {
            self.stream = VecDeque::new();
        }
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
    use std::collections::HashMap;

    #[test]
    fn clients_take_turns_one_message_each() {
        let (a, b) = (ClientKey([0, 0, 0, 1]), ClientKey([0, 0, 0, 2]));
        let mut boxes: HashMap<ClientKey, Outbox> = HashMap::new();
        let mut turns = TurnLists::default();
        for (key, tag) in [(a, 1u8), (a, 2), (a, 3), (b, 10)] {
            let out = boxes.entry(key).or_default();
            assert_eq!(out.push_stream(vec![tag], 100), None);
            turns.enlist(key, out, Class::Stream);
        }
        let mut sent = Vec::new();
        while let Some(key) = turns.pop(Class::Stream) {
            let out = boxes.get_mut(&key).unwrap();
            sent.push(out.pop_stream().unwrap()[0]);
            if out.has(Class::Stream) {
                turns.requeue(Class::Stream, key);
            } else {
                out.set_listed(Class::Stream, false);
            }
        }
        assert_eq!(sent, vec![1, 10, 2, 3], "one message per client in turn");
        assert!(boxes.values().all(Outbox::is_empty));
    }

    #[test]
    fn a_full_stream_queue_drops_its_oldest_and_control_is_bounded_apart() {
        let mut out = Outbox::default();
        assert_eq!(out.push_stream(vec![1], 2), None);
        assert_eq!(out.push_stream(vec![2], 2), None);
        assert_eq!(out.push_stream(vec![3], 2), Some(vec![1]));
        assert_eq!(out.push_control(Control::Heartbeat(0x80)), Ok(()));
        assert_eq!(out.push_control(Control::Heartbeat(0x80)), Ok(()));
        assert_eq!(out.len(), 3, "one HEARTBEAT intent per stream");
        for i in 1..MAX_CONTROL_QUEUE {
            assert_eq!(out.push_control(Control::Message(vec![i as u8])), Ok(()));
        }
        assert_eq!(
            out.push_control(Control::Message(vec![7])),
            Err(Control::Message(vec![7])),
            "the newest is refused"
        );
        assert_eq!(out.pop_control(), Some(Control::Heartbeat(0x80)), "queued control messages are kept");
    }

    #[test]
    fn trim_frees_only_empty_queues() {
        let mut out = Outbox::default();
        assert_eq!(out.push_stream(vec![1], 4), None);
        assert_eq!(out.push_control(Control::Heartbeat(0x80)), Ok(()));
        assert_eq!(out.pop_control(), Some(Control::Heartbeat(0x80)));
        out.trim();
        assert_eq!(out.control.capacity(), 0, "the emptied control queue keeps no buffer");
        assert_eq!(out.pop_stream(), Some(vec![1]), "a waiting stream message stays queued");
        out.trim();
        assert_eq!(out.stream.capacity(), 0);
    }
}
