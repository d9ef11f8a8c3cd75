//! The compared chain variants, each run through [`CoreRunner`] exactly as `dbe process` runs
//! it: the frame is fed chirp by chirp through `push_chirp`, then processed.
//!
//! A variant is a chain (DBE or FFT) and the DBE parameters; the FFT chain takes
//! `FftParams::from_dbe` of them (same windows, range bins, grids, TDM switch and sub-grid
//! switch; its own CA-CFAR). Every variant of a frame sees the same ADC samples.

use dbe_radar::{FrameStats, Params};

use super::EvalError;
use crate::cloud::PointRecord;
use crate::core_run::{Chain, CoreRunner};
use crate::frame::AdcFrame;
use crate::sensor::SensorConfig;

/// A named chain configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// Short name used in tables (`dbe`, `fft-grid`, …).
    pub name: String,
    /// Which chain.
    pub chain: Chain,
    /// The DBE parameters (the FFT chain uses `FftParams::from_dbe` of them).
    pub params: Params,
}

impl Variant {
    /// A DBE-chain variant.
    pub fn dbe(name: impl Into<String>, params: Params) -> Self {
        Self {
            name: name.into(),
            chain: Chain::Dbe,
            params,
        }
    }

    /// An FFT-chain variant.
    pub fn fft(name: impl Into<String>, params: Params) -> Self {
        Self {
            name: name.into(),
            chain: Chain::Fft,
            params,
        }
    }
}

/// What one variant produced for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainOutput {
    /// The points.
    pub points: Vec<PointRecord>,
    /// The frame statistics.
    pub stats: FrameStats,
}

/// Per-thread runners, one per variant, created on first use (each holds its own cube and
/// workspace on the heap).
#[derive(Debug, Default)]
pub struct Buffers {
    runners: Vec<Option<CoreRunner>>,
}

impl Buffers {
    /// No runner yet.
    pub fn new() -> Self {
        Self::default()
    }
}

/// The variants, checked against the sensor.
#[derive(Clone, Debug)]
pub struct Bench {
    sensor: SensorConfig,
    variants: Vec<Variant>,
}

impl Bench {
    /// Check that every variant configures on `sensor` (a configuration error names the
    /// variant).
    pub fn new(sensor: &SensorConfig, variants: Vec<Variant>) -> Result<Self, EvalError> {
        for v in &variants {
            CoreRunner::with_chain(sensor, v.params, v.chain).map_err(|source| {
                EvalError::Core {
                    variant: v.name.clone(),
                    source,
                }
            })?;
        }
        Ok(Self {
            sensor: sensor.clone(),
            variants,
        })
    }

    /// The variants, in index order.
    pub fn variants(&self) -> &[Variant] {
        &self.variants
    }

    /// Index of the variant called `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.variants.iter().position(|v| v.name == name)
    }

    /// Run the variants `which` (indices; out-of-range indices give `None`) on `frame`.
    /// Output `i` belongs to `which[i]`.
    pub fn run(
        &self,
        frame: &AdcFrame,
        which: &[usize],
        buf: &mut Buffers,
    ) -> Result<Vec<Option<ChainOutput>>, EvalError> {
        if buf.runners.len() < self.variants.len() {
            buf.runners.resize_with(self.variants.len(), || None);
        }
        let mut out = Vec::with_capacity(which.len());
        for &i in which {
            let (Some(v), Some(slot)) = (self.variants.get(i), buf.runners.get_mut(i)) else {
                out.push(None);
                continue;
            };
            let fail = |source| EvalError::Core {
                variant: v.name.clone(),
                source,
            };
            let runner = match slot {
                Some(r) => r,
                None => slot
                    .insert(CoreRunner::with_chain(&self.sensor, v.params, v.chain).map_err(fail)?),
            };
            let o = runner.process_points(frame).map_err(fail)?;
            out.push(Some(ChainOutput {
                points: o.points,
                stats: o.stats,
            }));
        }
        Ok(out)
    }
}
