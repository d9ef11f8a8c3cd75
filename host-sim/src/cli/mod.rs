//! The `dbe` subcommands.

/// `println!` that returns the write's error instead of panicking, for `?`: a reader that
/// closes the pipe early (`dbe validate … | head`) ends the command quietly ([`closed_pipe`]).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)
    }};
}

/// `print!` that returns the write's error (see `outln!`).
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        write!(std::io::stdout().lock(), $($arg)*)
    }};
}

pub mod bench;
pub mod calibrate;
pub mod demo;
pub mod eval;
pub mod input;
pub mod odometry;
pub mod plot;
pub mod process;
pub mod simulate;
pub mod validate;

use anyhow::Result;
use clap::Args;
use host_sim::sensor::SensorConfig;

/// Processing parameters a user may want to change; everything else keeps the spec's defaults.
#[derive(Args, Debug, Clone, Default)]
pub struct ParamArgs {
    /// Turn TDM-MIMO motion compensation off (reproduces the paper's chain).
    #[arg(long)]
    pub no_tdm_compensation: bool,
    /// CFAR threshold α over the noise level, dB, in [−10, 60] [default: 2].
    #[arg(long, value_name = "DB", allow_negative_numbers = true)]
    pub cfar_threshold_db: Option<f32>,
    /// CFAR order-statistic quantile q: the noise level is the ⌈q·n⌉-th smallest of the n
    /// training cells, q in (0, 1] [default: 0.75].
    #[arg(long, value_name = "Q")]
    pub cfar_quantile: Option<f32>,
    /// CFAR window gate, dB, in [0, 60]: a detection more than this below the strongest cell
    /// of its CFAR window (a strong neighbour's range skirt) is dropped; 0 turns it off
    /// [default: 12; the paper's chain: 0].
    #[arg(long, value_name = "DB")]
    pub cfar_window_gate_db: Option<f32>,
    /// Diagonal loading γ (δ = γ·tr(R)/M), in (0, 1] [default: 0.01].
    #[arg(long, value_name = "GAMMA", allow_negative_numbers = true)]
    pub loading: Option<f32>,
    /// Points on the spec's grid: no sub-grid refinement of range, azimuth, elevation and
    /// Doppler (by default the coordinates are continuous; bin indices are the same either way).
    #[arg(long)]
    pub grid: bool,
    /// Sub-grid refinement (the default; kept so that older scripts run).
    #[arg(long, hide = true)]
    pub subgrid: bool,
    /// Resolve every detection on the full array, also coherent ones (two targets of one range
    /// bin with one Doppler), as the paper's chain does; by default those use the
    /// forward–backward averaged 2 × 4 sub-array and get their own elevations. Implies
    /// --no-coherent-split.
    #[arg(long)]
    pub no_coherent: bool,
    /// Turn the coherent split off: by default a coherent pair merged into one detection of
    /// the range–azimuth map (nearly rank-1 azimuth covariance that two exponentials fit far
    /// better than one) is resolved as two detections (`Params::coherent_split`).
    #[arg(long)]
    pub no_coherent_split: bool,
    /// Turn the ring split on: a point at the horizon whose elevation row sees it clearly
    /// weaker than its azimuth line does (the two returns of a vertical surface's range ring,
    /// above and below the radar) becomes two points at the pair's elevations
    /// (`Params::ring_split`). Better ego-velocity and odometry on scenes with walls and poles
    /// beside the path, less accurate points (`dbe eval`).
    #[arg(long)]
    pub ring_split: bool,
    /// Spatially smooth the azimuth covariance over two 7-element sub-lines: coherent pairs
    /// 12° or more apart are always resolved, at the cost of one element of azimuth aperture.
    #[arg(long)]
    pub spatial_smoothing: bool,
    /// Fit the elevations of each range bin's points together (deterministic model, each
    /// point's own TDM slot phase, the points of the two neighbouring range bins included):
    /// crowded range bins of point scatterers get their elevations right where the per-point
    /// Capon sweep pulls them together; off by default (`Params::joint_elevation`).
    #[arg(long)]
    pub joint_elevation: bool,
    /// The paper's chain: no TDM-MIMO compensation, no coherent sub-array or split, no Doppler
    /// test, no Doppler agreement, no CFAR window gate, points on the grid (the other options
    /// still apply on top).
    #[arg(long)]
    pub paper: bool,
    /// Turn the Doppler test off: by default a detection whose azimuth Capon beam (after TDM
    /// compensation) has no slow-time peak 12 dB over its Doppler spectrum's median is dropped
    /// (`Params::doppler_test_db`).
    #[arg(long)]
    pub no_doppler_test: bool,
    /// Doppler test threshold, dB, in [0, 60]: how far a detection's azimuth Capon beam must
    /// peak over its Doppler spectrum's median; 0 turns the test off [default: 12].
    #[arg(long, value_name = "DB", conflicts_with = "no_doppler_test")]
    pub doppler_test_db: Option<f32>,
    /// Turn the Doppler agreement off: by default a point whose own Capon beam peaks more than
    /// 1.5 Doppler bins from its detection's azimuth beam is dropped
    /// (`Params::doppler_agreement_bins`).
    #[arg(long)]
    pub no_doppler_agreement: bool,
}

impl ParamArgs {
    /// The core's parameters for `sensor`'s sizes with these overrides.
    pub fn to_params(&self, sensor: &SensorConfig) -> Result<dbe_radar::Params> {
        let mut p = match self.paper {
            true => dbe_radar::Params::paper(sensor.samples),
            false => dbe_radar::Params::defaults(sensor.samples),
        };
        p.tdm_compensation = !self.no_tdm_compensation && !self.paper;
        if self.no_doppler_test {
            p.doppler_test_db = 0.0;
        }
        if let Some(t) = self.doppler_test_db {
            // The core's own bound (`Params::validate`).
            if !(0.0..=60.0).contains(&t) {
                anyhow::bail!("--doppler-test-db {t}: expected a value in [0, 60] dB");
            }
            p.doppler_test_db = t;
        }
        if self.no_doppler_agreement {
            p.doppler_agreement_bins = 0.0;
        }
        if self.grid {
            p.subgrid = false;
        } else if self.subgrid {
            p.subgrid = true;
        }
        if self.no_coherent {
            p.coherent_doppler_bins = 0.0;
            p.coherent_split = false;
        }
        if self.no_coherent_split {
            p.coherent_split = false;
        }
        p.ring_split = self.ring_split;
        p.spatial_smoothing = self.spatial_smoothing;
        p.joint_elevation = self.joint_elevation;
        if let Some(t) = self.cfar_threshold_db {
            // Below −10 dB every local maximum is a detection; above 60 dB nothing a 16-bit
            // ADC can record passes.
            if !(-10.0..=60.0).contains(&t) {
                anyhow::bail!("--cfar-threshold-db {t}: expected a value in [-10, 60] dB");
            }
            p.cfar.threshold_db = t;
        }
        if let Some(g) = self.cfar_window_gate_db {
            if !(0.0..=60.0).contains(&g) {
                anyhow::bail!("--cfar-window-gate-db {g}: expected a value in [0, 60] dB");
            }
            p.cfar.window_gate_db = g;
        }
        if let Some(q) = self.cfar_quantile {
            if !(q > 0.0 && q <= 1.0) {
                anyhow::bail!("--cfar-quantile {q}: expected a value in (0, 1]");
            }
            p.cfar.kind = dbe_radar::cfar::CfarKind::OrderStatistic { quantile: q };
        }
        if let Some(g) = self.loading {
            // γ is a fraction of the mean antenna power: above 1 the loading outweighs the
            // data and Capon degenerates into a plain beamscan.
            if !(g > 0.0 && g <= 1.0) {
                anyhow::bail!("--loading {g}: expected a value in (0, 1]");
            }
            p.loading = g;
        }
        Ok(p)
    }
}

/// Whether `e` is standard output's reader having gone away (`| head`): not a failure of the
/// command, which has nothing left to say.
pub fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// One line for an error and its causes, `outer: cause: …`, each cause once: an error whose
/// message already quotes its source (`"{path}: {source}"`) is not followed by the source again.
pub fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.is_empty() {
            line = text;
        } else if !line.ends_with(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
    }
    printable(&line)
}

/// `text` with every control character (ESC, BEL, CR, newline, …) written as its Rust escape
/// (`\u{1b}`, `\n`): file names and file contents quoted in an error cannot recolour the
/// terminal, move its cursor or split the one-line error.
pub fn printable(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_quoted_source_is_printed_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "gone");
        let quoted = host_sim::sim::SimError::Io {
            path: "a.toml".into(),
            source: io,
        };
        let e = anyhow::Error::new(quoted).context("loading the scene");
        assert_eq!(super::error_line(&e), "loading the scene: a.toml: gone");
        let e = anyhow::anyhow!("inner").context("outer\n");
        assert_eq!(super::error_line(&e), "outer\\n: inner");
    }

    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(
            super::printable("a\u{1b}[31mb\u{7}\nc é"),
            "a\\u{1b}[31mb\\u{7}\\nc é"
        );
    }
}
