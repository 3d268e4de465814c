//! `footprint-publisher` over a packet transport without framing (a message per write, whatever the UART holds
//! per read), the counterpart of the host probe's UDP socket: the client without the serial framing codec. For
//! its size only: an agent's serial transport expects frames.
#![no_std]
#![no_main]

use xrce_client::transport::{CustomIo, Transport, TransportError};

const MTU: usize = 512;
const OUT_HISTORY: usize = 4;
const OUT_BUFFER: usize = MTU * OUT_HISTORY;
const IN_HISTORY: usize = 4;
const IN_BUFFER: usize = MTU * IN_HISTORY;
const ONE_BY_ONE: bool = false;

/// Whole messages straight on the UART.
struct Link(xrce_board::Uart);

impl Transport for Link {
    fn mtu(&self) -> usize {
        MTU
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        self.0.write(msg).map(|_| ())
    }

    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        let n = self.0.read(buf, timeout_ms)?;
        Ok((n > 0).then_some(n))
    }
}

fn link() -> Option<Link> {
    Some(Link(xrce_board::Uart))
}

include!("../probe.rs");
