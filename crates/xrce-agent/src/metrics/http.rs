//! A bounded HTTP/1.1 server for one resource, `GET /metrics`, on one thread over `mio`.
//!
//! Bounds, so that no client can grow its memory or hold it: at most [`MAX_CONNECTIONS`] connections (a
//! new one past it closes the oldest, so idle connections cannot lock a scraper out), a request of at most
//! [`MAX_REQUEST_BYTES`] (longer: 431 and closed), [`CONNECTION_TIMEOUT`] per connection from accept to the
//! last byte of the answer (a request trickled a byte a second is closed then), one request per connection
//! (`Connection: close`; after the answer the server reads and drops what the client still sends until it
//! closes, so that an answer to a request still being sent is not lost to a reset). Anything but
//! `GET /metrics`: 404, or 405 for another method on `/metrics`.

use std::io::{self, Read, Write};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use mio::net::{TcpListener, TcpStream};
use mio::{Events, Interest, Poll, Token};

use super::render::render;
use crate::core::{AgentSnapshot, SnapshotBoard};

/// Connections open at once, at most.
pub const MAX_CONNECTIONS: usize = 64;
/// Longest request (line and headers) read.
pub const MAX_REQUEST_BYTES: usize = 8 * 1024;
/// Longest a connection stays open, request and answer together.
pub const CONNECTION_TIMEOUT: Duration = Duration::from_secs(10);

/// The server's bounds (the constants above by default; tests shorten them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Connections open at once; a new one past it closes the oldest.
    pub max_connections: usize,
    /// Longest request read; longer gets 431.
    pub max_request_bytes: usize,
    /// Longest a connection stays open.
    pub connection_timeout: Duration,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_connections: MAX_CONNECTIONS,
            max_request_bytes: MAX_REQUEST_BYTES,
            connection_timeout: CONNECTION_TIMEOUT,
        }
    }
}

/// How often the server looks for a new snapshot to render while scrapes come.
const RENDER_CHECK: Duration = Duration::from_millis(100);
/// A scrape within this long means more are coming: new snapshots are rendered ahead of them.
const SCRAPES_EXPECTED: Duration = Duration::from_secs(120);

const LISTENER: Token = Token(0);
const WAKER: Token = Token(1);
/// Connection `i` has token `FIRST_CONNECTION + i`.
const FIRST_CONNECTION: usize = 2;

/// What is left to send of an answer: its head, then the body it shares with other connections.
struct Answer {
    head: Vec<u8>,
    body: Arc<[u8]>,
    sent: usize,
}

impl Answer {
    fn remaining(&self) -> (&[u8], &[u8]) {
        let head = self.head.get(self.sent..).unwrap_or(&[]);
        let body = self.body.get(self.sent.saturating_sub(self.head.len())..).unwrap_or(&[]);
        (head, body)
    }
}

struct Connection {
    stream: TcpStream,
    opened: Instant,
    request: Vec<u8>,
    answer: Option<Answer>,
    /// The answer is sent and the write side shut: what the client still sends is read and dropped until it
    /// closes (a lingering close: closing with unread input would reset the connection, and the client
    /// could lose the answer, a 431 to a request still being sent, say).
    draining: bool,
}

/// The server: its listener, connections, and the text of the latest snapshot it rendered.
pub struct Server {
    poll: Poll,
    listener: TcpListener,
    waker: Arc<mio::Waker>,
    board: Arc<SnapshotBoard>,
    connections: Vec<Option<Connection>>,
    rendered: Option<(Arc<AgentSnapshot>, Arc<[u8]>)>,
    limits: Limits,
    /// When `/metrics` was last asked for: while scrapes come, each new snapshot is rendered as soon as it
    /// is published, so a scrape finds its text ready.
    last_scrape: Option<Instant>,
}

impl Server {
    /// Binds `addr`, with the default [`Limits`].
    pub fn bind(addr: SocketAddr, board: Arc<SnapshotBoard>) -> io::Result<Self> {
        Self::bind_with(addr, board, Limits::default())
    }

    /// Binds `addr` with `limits`.
    pub fn bind_with(addr: SocketAddr, board: Arc<SnapshotBoard>, limits: Limits) -> io::Result<Self> {
        let poll = Poll::new()?;
        let mut listener = TcpListener::bind(addr)?;
        poll.registry().register(&mut listener, LISTENER, Interest::READABLE)?;
        let waker = Arc::new(mio::Waker::new(poll.registry(), WAKER)?);
        // A new snapshot wakes the server, which renders it at once while scrapes come: a scrape rarely
        // finds the latest snapshot unrendered (it then renders it itself, ~5-10 ms at 1,000 clients).
        let on_snapshot = waker.clone();
        board.watch(move || {
            let _ = on_snapshot.wake();
        });
        let connections = (0..limits.max_connections.max(1)).map(|_| None).collect();
        Ok(Self { poll, listener, waker, board, connections, rendered: None, limits, last_scrape: None })
    }

    /// The address it listens on.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    /// Wakes [`Self::run`] (to see its stop flag).
    pub fn waker(&self) -> Arc<mio::Waker> {
        self.waker.clone()
    }

    /// Serves until `stop` is set (and the waker called, or within a second).
    pub fn run(mut self, stop: &AtomicBool) -> io::Result<()> {
        let mut events = Events::with_capacity(128);
        while !stop.load(Ordering::Relaxed) {
            let wait = self.next_deadline().map_or(RENDER_CHECK, |d| {
                d.saturating_duration_since(Instant::now()).clamp(Duration::from_millis(1), RENDER_CHECK)
            });
            if let Err(e) = self.poll.poll(&mut events, Some(wait)) {
                if e.kind() != io::ErrorKind::Interrupted {
                    return Err(e);
                }
            }
            for event in &events {
                match event.token() {
                    LISTENER => self.accept_all(),
                    WAKER => {}
                    Token(t) => self.serve(t.wrapping_sub(FIRST_CONNECTION)),
                }
            }
            let now = Instant::now();
            self.close_expired(now);
            if self.last_scrape.is_some_and(|at| now.saturating_duration_since(at) < SCRAPES_EXPECTED) {
                // Ahead of the next scrape; a no-op when the latest snapshot is rendered already.
                let _ = self.metrics_text();
            }
        }
        Ok(())
    }

    fn next_deadline(&self) -> Option<Instant> {
        self.connections.iter().flatten().map(|c| c.opened + self.limits.connection_timeout).min()
    }

    fn accept_all(&mut self) {
        loop {
            let (stream, _) = match self.listener.accept() {
                Ok(accepted) => accepted,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return,
                Err(e) => {
                    // Out of descriptors, a reset before accept: the next readiness tries again.
                    tracing::debug!("metrics: accept failed: {e}");
                    return;
                }
            };
            let slot = match self.connections.iter().position(Option::is_none) {
                Some(free) => free,
                None => self.close_oldest(),
            };
            let mut conn =
                Connection { stream, opened: Instant::now(), request: Vec::new(), answer: None, draining: false };
            let token = Token(FIRST_CONNECTION + slot);
            if self.poll.registry().register(&mut conn.stream, token, Interest::READABLE).is_ok() {
                if let Some(s) = self.connections.get_mut(slot) {
                    *s = Some(conn);
                }
            }
        }
    }

    /// Closes the connection open the longest; returns its slot.
    fn close_oldest(&mut self) -> usize {
        let oldest = self
            .connections
            .iter()
            .enumerate()
            .filter_map(|(i, c)| c.as_ref().map(|c| (i, c.opened)))
            .min_by_key(|(_, opened)| *opened)
            .map_or(0, |(i, _)| i);
        self.close(oldest);
        oldest
    }

    fn close(&mut self, slot: usize) {
        if let Some(mut conn) = self.connections.get_mut(slot).and_then(Option::take) {
            let _ = self.poll.registry().deregister(&mut conn.stream);
        }
    }

    fn close_expired(&mut self, now: Instant) {
        for slot in 0..self.connections.len() {
            let expired = self
                .connections
                .get(slot)
                .and_then(Option::as_ref)
                .is_some_and(|c| now.saturating_duration_since(c.opened) >= self.limits.connection_timeout);
            if expired {
                self.close(slot);
            }
        }
    }

    /// Reads what a connection sent, answers once its request is complete, writes what the socket takes.
    fn serve(&mut self, slot: usize) {
        let Some(Some(conn)) = self.connections.get_mut(slot) else { return };
        let keep = if conn.draining {
            drain(conn)
        } else if conn.answer.is_none() {
            match read_request(conn, self.limits.max_request_bytes) {
                Ok(Some(status)) => {
                    let answer = self.answer(status);
                    self.start_answer(slot, answer)
                }
                Ok(None) => true,
                Err(_) => false,
            }
        } else {
            self.write_some(slot)
        };
        if !keep {
            self.close(slot);
        }
    }

    /// The answer to a request whose routing gave `route`.
    fn answer(&mut self, route: Route) -> Answer {
        let (status, extra, body): (&str, &str, Arc<[u8]>) = match route {
            Route::Metrics => match self.scraped() {
                Some(body) => ("200 OK", "Content-Type: text/plain; version=0.0.4; charset=utf-8\r\n", body),
                None => ("503 Service Unavailable", "", Arc::from(&b"no snapshot yet\n"[..])),
            },
            Route::MethodNotAllowed => ("405 Method Not Allowed", "Allow: GET\r\n", Arc::from(&b"GET only\n"[..])),
            Route::NotFound => ("404 Not Found", "", Arc::from(&b"see /metrics\n"[..])),
            Route::TooLarge => ("431 Request Header Fields Too Large", "", Arc::from(&b"request too large\n"[..])),
            Route::BadRequest => ("400 Bad Request", "", Arc::from(&b"bad request\n"[..])),
        };
        let head = format!("HTTP/1.1 {status}\r\n{extra}Content-Length: {}\r\nConnection: close\r\n\r\n", body.len());
        Answer { head: head.into_bytes(), body, sent: 0 }
    }

    /// [`Self::metrics_text`] for a scrape.
    fn scraped(&mut self) -> Option<Arc<[u8]>> {
        self.last_scrape = Some(Instant::now());
        self.metrics_text()
    }

    /// The text of the latest snapshot, rendered once per snapshot.
    fn metrics_text(&mut self) -> Option<Arc<[u8]>> {
        let latest = self.board.latest()?;
        if let Some((snapshot, text)) = &self.rendered {
            if Arc::ptr_eq(snapshot, &latest) {
                return Some(text.clone());
            }
        }
        let text: Arc<[u8]> = Arc::from(render(latest.clone()).into_bytes());
        self.rendered = Some((latest, text.clone()));
        Some(text)
    }

    fn start_answer(&mut self, slot: usize, answer: Answer) -> bool {
        let Some(Some(conn)) = self.connections.get_mut(slot) else { return false };
        conn.answer = Some(answer);
        conn.request = Vec::new();
        let token = Token(FIRST_CONNECTION + slot);
        if self.poll.registry().reregister(&mut conn.stream, token, Interest::WRITABLE).is_err() {
            return false;
        }
        self.write_some(slot)
    }

    /// Writes what the socket takes; false once done (or failed): the connection closes.
    fn write_some(&mut self, slot: usize) -> bool {
        let Some(Some(conn)) = self.connections.get_mut(slot) else { return false };
        let Some(answer) = &mut conn.answer else { return false };
        loop {
            let (head, body) = answer.remaining();
            let chunk = if head.is_empty() { body } else { head };
            if chunk.is_empty() {
                // All sent: linger until the client closes (or the connection's time is up).
                conn.draining = true;
                let token = Token(FIRST_CONNECTION + slot);
                return conn.stream.shutdown(std::net::Shutdown::Write).is_ok()
                    && self.poll.registry().reregister(&mut conn.stream, token, Interest::READABLE).is_ok()
                    && drain(conn);
            }
            match conn.stream.write(chunk) {
                Ok(0) => return false,
                Ok(n) => answer.sent += n,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return true,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(_) => return false,
            }
        }
    }
}

/// Reads and drops what a lingering connection sends; false once it closed (or failed).
fn drain(conn: &mut Connection) -> bool {
    let mut sink = [0u8; 2048];
    loop {
        match conn.stream.read(&mut sink) {
            Ok(0) => return false,
            Ok(_) => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return true,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(_) => return false,
        }
    }
}

/// Where a request goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    Metrics,
    MethodNotAllowed,
    NotFound,
    TooLarge,
    BadRequest,
}

/// Reads what arrived; `Some(route)` once the request is complete (or refused), `None` while it is not.
/// An error (or end of stream) closes the connection.
fn read_request(conn: &mut Connection, max_request_bytes: usize) -> io::Result<Option<Route>> {
    let mut chunk = [0u8; 2048];
    loop {
        match conn.stream.read(&mut chunk) {
            Ok(0) => return Err(io::ErrorKind::UnexpectedEof.into()),
            Ok(n) => {
                let room = max_request_bytes.saturating_sub(conn.request.len());
                conn.request.extend_from_slice(chunk.get(..n.min(room)).unwrap_or(&[]));
                if let Some(route) = route(&conn.request) {
                    return Ok(Some(route));
                }
                if n > room {
                    return Ok(Some(Route::TooLarge));
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(None),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// The route [`route`] gives a request, by name: the fuzz target's entry point to the private parser (the
/// bytes a scraper sends are network input). Not an API.
#[doc(hidden)]
pub fn route_name(request: &[u8]) -> Option<&'static str> {
    route(request).map(|r| match r {
        Route::Metrics => "metrics",
        Route::MethodNotAllowed => "method not allowed",
        Route::NotFound => "not found",
        Route::TooLarge => "too large",
        Route::BadRequest => "bad request",
    })
}

/// The route of a request, once its head is complete.
fn route(request: &[u8]) -> Option<Route> {
    let mut headers = [httparse::EMPTY_HEADER; 32];
    let mut req = httparse::Request::new(&mut headers);
    match req.parse(request) {
        Ok(httparse::Status::Complete(_)) => {}
        Ok(httparse::Status::Partial) => return None,
        Err(httparse::Error::TooManyHeaders) => return Some(Route::TooLarge),
        Err(_) => return Some(Route::BadRequest),
    }
    let path = req.path.unwrap_or("");
    // A query string (`/metrics?x=1`, as some scrapers add) names the same resource.
    let path = path.split('?').next().unwrap_or(path);
    Some(match (req.method, path) {
        (Some("GET"), "/metrics") => Route::Metrics,
        (_, "/metrics") => Route::MethodNotAllowed,
        _ => Route::NotFound,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn routes() {
        assert_eq!(route(b"GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n"), Some(Route::Metrics));
        assert_eq!(route(b"GET /metrics?a=1 HTTP/1.0\r\n\r\n"), Some(Route::Metrics));
        assert_eq!(route(b"POST /metrics HTTP/1.1\r\n\r\n"), Some(Route::MethodNotAllowed));
        assert_eq!(route(b"GET / HTTP/1.1\r\n\r\n"), Some(Route::NotFound));
        assert_eq!(route(b"GET /metrics HTTP/1.1\r\nHost"), None, "incomplete");
        assert_eq!(route(b"\x00\x01 garbage\r\n\r\n"), Some(Route::BadRequest));
    }
}
