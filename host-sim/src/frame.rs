//! One frame of raw ADC data with runtime sizes, in TDM arrival order.

/// Raw ADC samples of one frame, `data[((k·tx + t)·rx + r)·samples + n] = [I, Q]`: loop `k`,
/// TX slot `t`, RX `r`, sample `n` — the order in which a DMA delivers chirps.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdcFrame {
    /// Complex samples per chirp.
    pub samples: usize,
    /// Loops per frame.
    pub loops: usize,
    /// TX slots.
    pub tx: usize,
    /// RX channels.
    pub rx: usize,
    /// Samples in TDM order, see the type's docs.
    pub data: Vec<[i16; 2]>,
}

impl AdcFrame {
    /// An all-zero frame.
    pub fn zeros(samples: usize, loops: usize, tx: usize, rx: usize) -> Self {
        Self {
            samples,
            loops,
            tx,
            rx,
            data: vec![[0, 0]; samples * loops * tx * rx],
        }
    }

    /// Flat index of loop `k`, TX `t`, RX `r`, sample `n`.
    #[inline]
    pub fn index(&self, k: usize, t: usize, r: usize, n: usize) -> usize {
        ((k * self.tx + t) * self.rx + r) * self.samples + n
    }

    /// All RX of chirp (`k`, `t`): `rx · samples` pairs, RX-major.
    pub fn chirp(&self, k: usize, t: usize) -> &[[i16; 2]] {
        let start = self.index(k, t, 0, 0);
        &self.data[start..start + self.rx * self.samples]
    }
}
