//! Recycled byte buffers, shared by the core (messages out) and the CED middleware (samples kept and
//! taken): the hot path reuses them instead of allocating per message or sample. Bounded: at most
//! `max_free` buffers (default [`BufPool::MAX_FREE`]) of at most [`BufPool::MAX_CAPACITY`] bytes are kept.

/// A bounded free list of buffers.
#[derive(Debug)]
pub struct BufPool {
    free: Vec<Vec<u8>>,
    max_free: usize,
    /// Buffers created because none was free (diagnostics, tests).
    created: u64,
}

impl Default for BufPool {
    fn default() -> Self {
        Self::with_max_free(Self::MAX_FREE)
    }
}

impl BufPool {
    /// Most buffers kept by default.
    pub const MAX_FREE: usize = 512;
    /// Largest buffer kept (a bigger one is freed).
    pub const MAX_CAPACITY: usize = 4096;

    /// A pool keeping at most `max_free` buffers.
    pub fn with_max_free(max_free: usize) -> Self {
        Self { free: Vec::new(), max_free, created: 0 }
    }

    /// An empty buffer (a new one starts with room for 256 bytes).
    pub fn get(&mut self) -> Vec<u8> {
        self.free.pop().unwrap_or_else(|| self.create(256))
    }

    /// An empty buffer for `len` bytes. A free buffer much larger than needed is shrunk first, so buffers
    /// kept for a while (samples in a topic) never hold small data in large allocations; with data of one
    /// size, as usual, nothing is allocated once warm.
    pub fn get_fitted(&mut self, len: usize) -> Vec<u8> {
        match self.free.pop() {
            Some(mut buf) => {
                if buf.capacity() > 2 * len + 64 {
                    buf.shrink_to(len);
                }
                buf
            }
            None => self.create(len),
        }
    }

    /// A copy of `bytes` in a buffer from [`Self::get_fitted`].
    pub fn copy_fitted(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut buf = self.get_fitted(bytes.len());
        buf.extend_from_slice(bytes);
        buf
    }

    /// Returns a buffer for reuse.
    pub fn put(&mut self, mut buf: Vec<u8>) {
        if self.free.len() < self.max_free && buf.capacity() <= Self::MAX_CAPACITY {
            buf.clear();
            self.free.push(buf);
        }
    }

    /// Buffers created so far because none was free.
    pub fn created(&self) -> u64 {
        self.created
    }

    fn create(&mut self, capacity: usize) -> Vec<u8> {
        self.created = self.created.saturating_add(1);
        Vec::with_capacity(capacity)
    }
}
