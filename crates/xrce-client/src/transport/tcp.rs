//! TCP transport over IPv4 or IPv6 (`uxr_init_tcp_transport`): each message preceded by its length, 2 bytes
//! little endian (spec §12.2).

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};

use xrce_proto::framing::tcp::{prefix, TcpDecoder, TcpEvent};

use super::udp::{resolve, timeout, IpProtocol};
use super::{Transport, TransportError};
use crate::session::DEFAULT_MTU;

/// A TCP connection to one agent.
#[derive(Debug)]
pub struct TcpTransport {
    agent: SocketAddr,
    stream: TcpStream,
    decoder: TcpDecoder<[u8; DEFAULT_MTU]>,
    chunk: [u8; 256],
    pos: usize,
    len: usize,
}

impl TcpTransport {
    /// `uxr_init_tcp_transport`: connects to the agent at `ip`, `port`.
    pub fn new(protocol: IpProtocol, ip: &str, port: &str) -> Result<Self, TransportError> {
        Self::connect(resolve(protocol, ip, port)?)
    }

    /// Connects to the agent at `agent`.
    pub fn connect(agent: SocketAddr) -> Result<Self, TransportError> {
        Ok(Self {
            agent,
            stream: Self::stream(agent)?,
            decoder: TcpDecoder::new([0; DEFAULT_MTU]),
            chunk: [0; 256],
            pos: 0,
            len: 0,
        })
    }

    fn stream(agent: SocketAddr) -> Result<TcpStream, TransportError> {
        let stream = TcpStream::connect_timeout(&agent, std::time::Duration::from_secs(1))?;
        stream.set_nodelay(true)?;
        Ok(stream)
    }
}

impl Transport for TcpTransport {
    /// Connects again (the session's reconnection calls it after the connection failed); what was half read
    /// is dropped.
    fn open(&mut self) -> Result<(), TransportError> {
        self.stream = Self::stream(self.agent)?;
        self.decoder = TcpDecoder::new([0; DEFAULT_MTU]);
        self.pos = 0;
        self.len = 0;
        Ok(())
    }

    fn close(&mut self) -> Result<(), TransportError> {
        self.stream.shutdown(std::net::Shutdown::Both)?;
        Ok(())
    }

    fn send(&mut self, msg: &[u8]) -> Result<(), TransportError> {
        let head = prefix(msg.len()).map_err(|_| TransportError::MessageTooLarge)?;
        self.stream.write_all(&head)?;
        self.stream.write_all(msg)?;
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<Option<usize>, TransportError> {
        loop {
            if self.pos >= self.len {
                self.stream.set_read_timeout(timeout(timeout_ms))?;
                let n = match self.stream.read(&mut self.chunk) {
                    Ok(0) => return Err(TransportError::Closed),
                    Ok(n) => n,
                    Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => {
                        return Ok(None)
                    }
                    Err(e) => return Err(e.into()),
                };
                self.pos = 0;
                self.len = n;
            }
            let input = self.chunk.get(self.pos..self.len).unwrap_or(&[]);
            let (used, event) = self.decoder.feed(input);
            self.pos += used;
            if let Some(TcpEvent::Message(msg)) = event {
                let dst = buf.get_mut(..msg.len()).ok_or(TransportError::MessageTooLarge)?;
                xrce_proto::bytes::copy(dst, msg);
                return Ok(Some(msg.len()));
            }
        }
    }
}

/// The connected socket, for programs that poll it (the C library's `platform.poll_fd.fd`).
#[cfg(unix)]
impl std::os::fd::AsRawFd for TcpTransport {
    fn as_raw_fd(&self) -> std::os::fd::RawFd {
        std::os::fd::AsRawFd::as_raw_fd(&self.stream)
    }
}
