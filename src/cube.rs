//! The radar cube and its chirp-by-chirp ingestion bookkeeping.
//!
//! Layout: `cube[range bin][row][loop]` with rows in [`crate::config::ArrayLayout`] order, so
//! one range bin's `M × K` snapshot block is contiguous and its first `AZ` rows are the
//! azimuth line. The storage is caller-owned (a `static` on firmware, a `Box` on a host), so
//! no megabyte-sized value ever passes through the stack.

use core::fmt;

use num_complex::Complex32;

/// One range bin's snapshots: `M` rows × `K` loops.
pub type Snapshots<const M: usize, const K: usize> = [[Complex32; K]; M];

/// Storage of a whole cube: `N` range bins.
pub type CubeStorage<const N: usize, const M: usize, const K: usize> = [Snapshots<M, K>; N];

/// Which chirp of a frame: loop index `k` and TDM slot (TX data index) `t`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct ChirpId {
    /// Loop (slow-time) index, `0..K`.
    pub loop_index: u16,
    /// TX slot, `0..TX`.
    pub tx_slot: u8,
}

impl fmt::Display for ChirpId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "loop {} TX slot {}", self.loop_index, self.tx_slot)
    }
}

/// Why a frame cannot be processed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameError {
    /// A chirp arrived out of TDM order: one was missing, repeated or reordered.
    OutOfOrder {
        /// The chirp that was due.
        expected: ChirpId,
        /// The chirp that arrived.
        got: ChirpId,
    },
    /// More chirps than a frame holds arrived before the frame was processed.
    TooManyChirps,
    /// The frame was processed before all its chirps arrived.
    Incomplete {
        /// Chirps received.
        received: u32,
        /// Chirps a frame holds (`K · TX`).
        expected: u32,
    },
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::OutOfOrder { expected, got } => {
                write!(f, "chirp out of order: expected {expected}, got {got}")
            }
            FrameError::TooManyChirps => write!(f, "more chirps than a frame holds"),
            FrameError::Incomplete { received, expected } => {
                write!(
                    f,
                    "incomplete frame: {received} of {expected} chirps received"
                )
            }
        }
    }
}

impl core::error::Error for FrameError {}

/// A radar cube being filled chirp by chirp.
#[derive(Debug)]
pub struct Cube<'a, const N: usize, const M: usize, const K: usize> {
    bins: &'a mut CubeStorage<N, M, K>,
    received: u32,
    error: Option<FrameError>,
}

impl<'a, const N: usize, const M: usize, const K: usize> Cube<'a, N, M, K> {
    /// Wrap caller-owned storage; the cube starts empty, waiting for loop 0, slot 0.
    pub fn new(bins: &'a mut CubeStorage<N, M, K>) -> Self {
        Self {
            bins,
            received: 0,
            error: None,
        }
    }

    /// Start a new frame: forget the chirps received and any ingestion error.
    pub fn begin_frame(&mut self) {
        self.received = 0;
        self.error = None;
    }

    /// The range-FFT data.
    pub fn bins(&self) -> &CubeStorage<N, M, K> {
        self.bins
    }

    /// Chirps received in order so far in this frame.
    pub fn received(&self) -> u32 {
        self.received
    }

    /// `Ok` when all `K · tx` chirps arrived in order, else why not.
    pub fn status(&self, tx: usize) -> Result<(), FrameError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let expected = (K * tx) as u32;
        if self.received != expected {
            return Err(FrameError::Incomplete {
                received: self.received,
                expected,
            });
        }
        Ok(())
    }

    /// Check `id` against the TDM order for `tx` slots; on success the caller writes the chirp
    /// into the loop index returned. A wrong chirp poisons the frame until [`Self::begin_frame`].
    pub(crate) fn accept(&mut self, id: ChirpId, tx: usize) -> Option<usize> {
        if self.error.is_some() || tx == 0 {
            return None;
        }
        let total = (K * tx) as u32;
        if self.received >= total {
            self.error = Some(FrameError::TooManyChirps);
            return None;
        }
        let expected = ChirpId {
            loop_index: (self.received as usize / tx) as u16,
            tx_slot: (self.received as usize % tx) as u8,
        };
        if id != expected {
            self.error = Some(FrameError::OutOfOrder { expected, got: id });
            return None;
        }
        self.received += 1;
        Some(usize::from(id.loop_index))
    }

    /// Write range bin `b` of row `row`, loop `k`.
    #[inline]
    pub(crate) fn set(&mut self, b: usize, row: usize, k: usize, v: Complex32) {
        if let Some(x) = self
            .bins
            .get_mut(b)
            .and_then(|s| s.get_mut(row))
            .and_then(|r| r.get_mut(k))
        {
            *x = v;
        }
    }
}
