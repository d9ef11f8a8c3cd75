//! `dbe eval`: the DBE chain against the FFT baseline chain and the Cramér–Rao bound, on
//! simulated frames with exact ground truth.
//!
//! # What is measured
//!
//! | experiment | frames | truth | module |
//! |---|---|---|---|
//! | angle and Doppler accuracy of one target vs SNR, beside the CRB | one point target, random angle, radial velocity and phase, Monte-Carlo | exact | [`scenarios::run_single`], [`crb`] |
//! | probability of resolving two equal targets vs azimuth separation, coherent and non-coherent | two point targets at one range | exact | [`scenarios::run_pairs`] |
//! | false points per frame | noise only | none | [`scenarios::run_noise`] |
//! | Chamfer distance, detection rate, false points, point-target accuracy | the scene files (corridor, outdoor poles and walls, cluttered room, parking lot, moving sensor) | surface samples + targets | [`scenarios::run_scenes`], [`chamfer`] |
//! | defaults (diagonal loading, CFAR α and quantile, elevation peak rules) | all of the above, shared frames | | [`defaults_sweep`] |
//!
//! Every frame is rendered once by the simulator ([`crate::sim`]) and fed, chirp by chirp,
//! to every chain variant through [`crate::core_run::CoreRunner`] exactly as `dbe process`
//! runs it ([`mod@bench`]): the chains see identical data. Variants: the DBE chain and the
//! FFT chain at their defaults, each on the grid (no sub-grid refinement), each with TDM compensation off.
//!
//! # Definitions
//!
//! - **SNR**: per antenna and chirp after the range FFT, in the target's range bin
//!   ([`snr`]); the per-ADC-sample SNR is 18.7 dB lower.
//! - **Cramér–Rao bound**: deterministic single source, known noise, all other parameters
//!   unknown, derived in [`crb`].
//! - **Detection**: a point within [`scenarios::MATCH_RADIUS_M`] (0.6 m) of the target; the
//!   estimate is the strongest such point (highest `intensity_db`). RMSEs are over detected
//!   trials; the detection rate is reported beside them.
//! - **Resolution**: [`scenarios::resolved`]: each target needs its own point, nearer to it than
//!   to the other target and closer than half the separation in azimuth, within 2 range bins.
//! - **False point**: farther than 0.6 m from every truth point (surface sample or target).
//! - **Chamfer distance**: symmetric mean of nearest-neighbour distances after voxel
//!   downsampling of both clouds ([`chamfer`]), per frame, averaged over frames.
//!
//! Reproducibility: every random draw follows from [`EvalConfig::seed`] and the trial's
//! indices ([`scenarios::trial_seed`]); the thread count changes nothing but the wall time.

pub mod bench;
pub mod chamfer;
pub mod chart;
pub mod crb;
pub mod csv;
pub mod figures;
pub mod goals;
pub mod maps;
pub mod odometry;
pub mod report;
pub mod scenarios;
pub mod snr;
pub mod surfaces;
pub mod tables;

use std::time::Instant;

use dbe_radar::presets::coloradar as p;
use dbe_radar::Params;

use bench::{Bench, Variant};
use scenarios::{Context, Pair, PairCase, SCENES};

pub use report::write_report;
pub use tables::Evaluation;

/// Why the evaluation failed.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// The core runner rejected a variant's configuration or a frame.
    #[error("variant {variant}: {source}")]
    Core {
        /// The variant.
        variant: String,
        /// The runner's reason.
        source: crate::core_run::CoreRunError,
    },
    /// The simulator failed (scene file, sensor or render input).
    #[error("simulator: {0}")]
    Sim(#[from] crate::sim::SimError),
    /// A Cramér–Rao bound could not be computed.
    #[error("Cramér–Rao bound: {0}")]
    Crb(#[from] crb::CrbError),
    /// The configuration asks for nothing, or for something impossible.
    #[error("evaluation configuration: {0}")]
    Setup(String),
    /// Writing the report failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
}

/// Sizes and seeds of one evaluation run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct EvalConfig {
    /// `--quick`: fewer trials and frames.
    pub quick: bool,
    /// Seed of every random draw.
    pub seed: u64,
    /// ADC noise standard deviation on I and Q, LSB (the scenes' default).
    pub noise_std: f64,
    /// SNRs of the single-target sweep, dB.
    pub snr_db: Vec<f64>,
    /// Trials per SNR.
    pub trials_per_snr: usize,
    /// Azimuth separations of the resolution sweep, degrees.
    pub separations_deg: Vec<f64>,
    /// SNR of each target in the resolution sweep, dB.
    pub resolution_snr_db: f64,
    /// SNRs of the resolution-vs-SNR check at [`Self::resolution_check_deg`].
    pub resolution_check_snr_db: Vec<f64>,
    /// Separation of the resolution-vs-SNR check, degrees (the goal's 8°).
    pub resolution_check_deg: f64,
    /// Trials per resolution case.
    pub trials_per_pair: usize,
    /// Noise-only frames.
    pub noise_frames: usize,
    /// Frames per scene, spread evenly over the first [`Self::scene_span`] frames.
    pub scene_frames: usize,
    /// Frames of the scenes' sequences the evaluated frames are spread over.
    pub scene_span: usize,
    /// Voxel resolutions of the Chamfer table, m (the paper's Table II).
    pub resolutions_m: Vec<f64>,
    /// Run the defaults sweep.
    pub sweep: bool,
    /// SNRs at which the sweep variants run on the single-target trials, dB.
    pub sweep_snr_db: Vec<f64>,
    /// Separations at which the sweep variants run on the resolution trials (both pair
    /// kinds), degrees.
    pub sweep_separations_deg: Vec<f64>,
    /// Seeds per odometry sequence (0: no odometry section).
    pub odometry_seeds: usize,
    /// Frames per odometry sequence at most (`None`: the whole sequence).
    pub odometry_frames: Option<usize>,
}

impl EvalConfig {
    /// The full evaluation (`dbe eval`).
    pub fn full() -> Self {
        Self {
            quick: false,
            seed: 2025,
            noise_std: 8.0,
            snr_db: (0..=14).map(|i| -5.0 + 2.5 * f64::from(i)).collect(),
            trials_per_snr: 150,
            separations_deg: vec![2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0],
            resolution_snr_db: 20.0,
            resolution_check_snr_db: vec![10.0, 15.0, 20.0, 25.0, 30.0],
            resolution_check_deg: 8.0,
            trials_per_pair: 80,
            noise_frames: 60,
            scene_frames: 20,
            scene_span: 50,
            resolutions_m: vec![0.2, 0.1, 0.05, 0.02, 0.01],
            sweep: true,
            sweep_snr_db: vec![2.5, 20.0],
            sweep_separations_deg: vec![6.0, 8.0],
            odometry_seeds: 5,
            odometry_frames: None,
        }
    }

    /// The quick evaluation (`dbe eval --quick`): the same code paths, fewer trials.
    pub fn quick() -> Self {
        Self {
            quick: true,
            snr_db: vec![-5.0, 0.0, 2.5, 5.0, 10.0, 20.0, 30.0],
            trials_per_snr: 16,
            separations_deg: vec![2.0, 4.0, 6.0, 8.0, 12.0, 20.0],
            resolution_check_snr_db: vec![10.0, 30.0],
            trials_per_pair: 8,
            noise_frames: 6,
            scene_frames: 2,
            odometry_seeds: 1,
            odometry_frames: Some(60),
            ..Self::full()
        }
    }

    fn check(&self) -> Result<(), EvalError> {
        let bad = |what: &str| Err(EvalError::Setup(what.to_string()));
        if self.snr_db.is_empty() || self.trials_per_snr == 0 {
            return bad("the single-target sweep needs at least one SNR and one trial");
        }
        if self.separations_deg.is_empty() || self.trials_per_pair == 0 {
            return bad("the resolution sweep needs at least one separation and one trial");
        }
        if self.scene_frames == 0 || self.scene_span == 0 || self.resolutions_m.is_empty() {
            return bad("the scene evaluation needs frames and resolutions");
        }
        let finite = self
            .snr_db
            .iter()
            .chain(&self.separations_deg)
            .chain(&self.resolutions_m)
            .chain(&self.resolution_check_snr_db)
            .chain([&self.noise_std, &self.resolution_snr_db]);
        if finite.clone().any(|v| !v.is_finite()) {
            return bad("every SNR, separation, resolution and noise level must be finite");
        }
        if self.resolutions_m.iter().any(|&r| r <= 0.0) || self.noise_std <= 0.0 {
            return bad("resolutions and the noise level must be positive");
        }
        Ok(())
    }
}

/// Names of the main variants, in [`main_variants`] order.
pub mod names {
    /// DBE chain, defaults.
    pub const DBE: &str = "dbe";
    /// FFT chain, defaults.
    pub const FFT: &str = "fft";
    /// DBE chain without sub-grid refinement (points on the grid).
    pub const DBE_GRID: &str = "dbe-grid";
    /// FFT chain without sub-grid refinement.
    pub const FFT_GRID: &str = "fft-grid";
    /// DBE chain without TDM compensation.
    pub const DBE_NO_TDM: &str = "dbe-tdm";
    /// FFT chain without TDM compensation.
    pub const FFT_NO_TDM: &str = "fft-tdm";
}

/// The compared variants: both chains at their defaults (sub-grid refinement on), on the grid,
/// and without TDM compensation.
pub fn main_variants() -> Vec<Variant> {
    let d = Params::defaults(p::SAMPLES);
    let grid = Params {
        subgrid: false,
        ..d
    };
    let no_tdm = Params {
        tdm_compensation: false,
        ..d
    };
    vec![
        Variant::dbe(names::DBE, d),
        Variant::fft(names::FFT, d),
        Variant::dbe(names::DBE_GRID, grid),
        Variant::fft(names::FFT_GRID, grid),
        Variant::dbe(names::DBE_NO_TDM, no_tdm),
        Variant::fft(names::FFT_NO_TDM, no_tdm),
    ]
}

/// One DBE parameter the defaults sweep varies, with its value.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub enum SweepValue {
    /// Diagonal loading γ.
    Loading(f32),
    /// CFAR threshold α, dB.
    CfarThreshold(f32),
    /// CFAR order-statistic quantile q.
    CfarQuantile(f32),
    /// Elevation peaks: at most `.0` per detection, within `.1` dB of the strongest.
    ElevationPeaks(u8, f32),
    /// The Doppler test's threshold, dB (0: off).
    DopplerTest(f32),
    /// The coherent-target Doppler window, bins (0: off).
    Coherent(f32),
    /// The Doppler agreement window, bins (0: off).
    DopplerAgreement(f32),
    /// The CFAR window gate, dB (0: off).
    WindowGate(f32),
    /// The joint elevation fit of each range bin's points (`Params::joint_elevation`).
    JointElevation(bool),
    /// The coherent split of merged coherent pairs (`Params::coherent_split`).
    CoherentSplit(bool),
    /// The ring split of vertical surfaces' returns (`Params::ring_split`).
    RingSplit(bool),
    /// CFAR α and Doppler test threshold together, dB (issue 10 §1: the range–azimuth map as
    /// a candidate stage below its own detection limit, the slow-time test as the detector).
    Detector(f32, f32),
}

impl SweepValue {
    /// The parameter's name.
    pub fn parameter(&self) -> &'static str {
        match self {
            SweepValue::Loading(_) => "loading γ",
            SweepValue::CfarThreshold(_) => "CFAR α (dB)",
            SweepValue::CfarQuantile(_) => "CFAR quantile q",
            SweepValue::ElevationPeaks(..) => "elevation peaks (max, range dB)",
            SweepValue::DopplerTest(_) => "Doppler test (dB)",
            SweepValue::Coherent(_) => "coherent window (bins)",
            SweepValue::DopplerAgreement(_) => "Doppler agreement (bins)",
            SweepValue::WindowGate(_) => "CFAR window gate (dB)",
            SweepValue::JointElevation(_) => "joint elevation fit",
            SweepValue::CoherentSplit(_) => "coherent split",
            SweepValue::RingSplit(_) => "ring split",
            SweepValue::Detector(..) => "CFAR α, Doppler test (dB)",
        }
    }

    /// The value as text.
    pub fn value(&self) -> String {
        match self {
            SweepValue::Loading(g) => format!("{g:e}"),
            SweepValue::CfarThreshold(a) => format!("{a}"),
            SweepValue::CfarQuantile(q) => format!("{q}"),
            SweepValue::ElevationPeaks(n, r) => format!("{n}, {r}"),
            SweepValue::Detector(a, t) => format!("{a}, {t}"),
            SweepValue::DopplerTest(t) => format!("{t}"),
            SweepValue::Coherent(c) => format!("{c}"),
            SweepValue::DopplerAgreement(g) => format!("{g}"),
            SweepValue::WindowGate(g) => format!("{g}"),
            SweepValue::JointElevation(on)
            | SweepValue::CoherentSplit(on)
            | SweepValue::RingSplit(on) => String::from(if *on { "on" } else { "off" }),
        }
    }

    /// `params` with this value applied.
    pub fn apply(&self, mut params: Params) -> Params {
        match *self {
            SweepValue::Loading(g) => params.loading = g,
            SweepValue::CfarThreshold(a) => params.cfar.threshold_db = a,
            SweepValue::CfarQuantile(q) => {
                params.cfar.kind = dbe_radar::CfarKind::OrderStatistic { quantile: q }
            }
            SweepValue::ElevationPeaks(n, r) => {
                params.elevation.max_peaks = n;
                params.elevation.peak_range_db = r;
            }
            SweepValue::DopplerTest(t) => params.doppler_test_db = t,
            SweepValue::Coherent(c) => params.coherent_doppler_bins = c,
            SweepValue::DopplerAgreement(g) => params.doppler_agreement_bins = g,
            SweepValue::WindowGate(g) => params.cfar.window_gate_db = g,
            SweepValue::JointElevation(on) => params.joint_elevation = on,
            SweepValue::CoherentSplit(on) => params.coherent_split = on,
            SweepValue::RingSplit(on) => params.ring_split = on,
            SweepValue::Detector(a, t) => {
                params.cfar.threshold_db = a;
                params.doppler_test_db = t;
            }
        }
        params
    }

    /// Whether this is the core's default value.
    pub fn is_default(&self) -> bool {
        let d = Params::defaults(p::SAMPLES);
        self.apply(d) == d
    }
}

/// The defaults sweep: one parameter at a time around the core's defaults (which are
/// included, as the `dbe` variant).
pub fn defaults_sweep() -> Vec<SweepValue> {
    let mut v = Vec::new();
    for g in [1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1] {
        v.push(SweepValue::Loading(g));
    }
    for a in [1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0, 12.0] {
        v.push(SweepValue::CfarThreshold(a));
    }
    for q in [0.25, 0.5, 0.625, 0.75, 0.875] {
        v.push(SweepValue::CfarQuantile(q));
    }
    for (n, r) in [(1, 6.0), (2, 3.0), (2, 6.0), (2, 10.0), (3, 6.0), (4, 10.0)] {
        v.push(SweepValue::ElevationPeaks(n, r));
    }
    for t in [0.0, 6.0, 12.0, 18.0] {
        v.push(SweepValue::DopplerTest(t));
    }
    for c in [0.0, 1.5] {
        v.push(SweepValue::Coherent(c));
    }
    for g in [0.0, 1.0, 1.5, 3.0] {
        v.push(SweepValue::DopplerAgreement(g));
    }
    for g in [0.0, 6.0, 9.0, 12.0, 15.0, 20.0] {
        v.push(SweepValue::WindowGate(g));
    }
    for on in [false, true] {
        v.push(SweepValue::JointElevation(on));
    }
    for on in [false, true] {
        v.push(SweepValue::CoherentSplit(on));
    }
    for on in [false, true] {
        v.push(SweepValue::RingSplit(on));
    }
    for (a, t) in [(2.0, 12.0), (1.0, 15.0), (1.0, 18.0), (0.5, 18.0)] {
        v.push(SweepValue::Detector(a, t));
    }
    v
}

/// Name of the sweep variant of `s` (the default value maps to the `dbe` variant).
pub fn sweep_name(s: &SweepValue) -> String {
    if s.is_default() {
        names::DBE.to_string()
    } else {
        format!("dbe[{} = {}]", s.parameter(), s.value())
    }
}

/// Run the whole evaluation. `progress` receives one line per stage.
pub fn run_evaluation(
    config: &EvalConfig,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Evaluation, EvalError> {
    config.check()?;
    let start = Instant::now();
    let ctx = Context::coloradar(config.noise_std)?;
    let mut variants = main_variants();
    let main: Vec<usize> = (0..variants.len()).collect();
    let sweep_values = if config.sweep {
        defaults_sweep()
    } else {
        Vec::new()
    };
    let mut extra = Vec::new();
    for s in sweep_values.iter().filter(|s| !s.is_default()) {
        extra.push(variants.len());
        variants.push(Variant::dbe(
            sweep_name(s),
            s.apply(Params::defaults(p::SAMPLES)),
        ));
    }
    let bench = Bench::new(&ctx.sensor, variants)?;
    let idx = |n: &str| {
        bench
            .index(n)
            .ok_or_else(|| EvalError::Setup(format!("variant {n} missing")))
    };
    let pair_variants = [
        idx(names::DBE)?,
        idx(names::FFT)?,
        idx(names::DBE_GRID)?,
        idx(names::FFT_GRID)?,
    ];
    let mut timings = Vec::new();
    let mut stage = |name: &str, t: Instant| {
        let s = t.elapsed().as_secs_f64();
        progress(&format!("   {name}: {s:.1} s"));
        timings.push((name.to_string(), s));
    };

    progress(&format!(
        "single target: {} SNRs × {} trials, {} variants (+{} sweep variants at {:?} dB)",
        config.snr_db.len(),
        config.trials_per_snr,
        main.len(),
        extra.len(),
        config.sweep_snr_db
    ));
    let t = Instant::now();
    let single = scenarios::run_single(
        &ctx,
        &bench,
        config.seed,
        &scenarios::SinglePlan {
            snr_db: &config.snr_db,
            trials: config.trials_per_snr,
            which: &main,
            extra: &extra,
            extra_snr_db: &config.sweep_snr_db,
        },
    )?;
    stage("single target", t);

    let mut cases = Vec::new();
    for pair in [Pair::Coherent, Pair::NonCoherent] {
        for &s in &config.separations_deg {
            cases.push(PairCase {
                separation_deg: s,
                pair,
                snr_db: config.resolution_snr_db,
                extra: config
                    .sweep_separations_deg
                    .iter()
                    .any(|&x| (x - s).abs() < 1e-9),
            });
        }
    }
    for &snr in &config.resolution_check_snr_db {
        if (snr - config.resolution_snr_db).abs() > 1e-9 {
            cases.push(PairCase {
                separation_deg: config.resolution_check_deg,
                pair: Pair::NonCoherent,
                snr_db: snr,
                extra: false,
            });
        }
    }
    progress(&format!(
        "two targets: {} cases × {} trials",
        cases.len(),
        config.trials_per_pair
    ));
    let t = Instant::now();
    let pairs = scenarios::run_pairs(
        &ctx,
        &bench,
        config.seed,
        &cases,
        config.trials_per_pair,
        &pair_variants,
        &extra,
    )?;
    stage("two targets", t);

    let all: Vec<usize> = (0..bench.variants().len()).collect();
    progress(&format!("noise only: {} frames", config.noise_frames));
    let t = Instant::now();
    let noise = scenarios::run_noise(&ctx, &bench, config.seed, config.noise_frames, &all)?;
    stage("noise only", t);

    progress(&format!(
        "scenes: {} scenes × {} frames",
        SCENES.len(),
        config.scene_frames
    ));
    let t = Instant::now();
    let scenes = scenarios::run_scenes(
        &ctx,
        &bench,
        &SCENES,
        config.scene_frames,
        config.scene_span,
        &config.resolutions_m,
        &all,
    )?;
    stage("scenes", t);

    let odometry = if config.odometry_seeds > 0 {
        progress(&format!(
            "odometry: {} sequences × {} seeds{}",
            odometry::SEQUENCES.len(),
            config.odometry_seeds,
            config
                .odometry_frames
                .map_or(String::new(), |n| format!(", first {n} frames"))
        ));
        let t = Instant::now();
        // The DBE chain, the FFT chain, and the DBE chain with the ring split, which is off
        // by default for the point clouds and measured here for the ego-velocity.
        let ring = sweep_name(&SweepValue::RingSplit(true));
        let rows = odometry::run_odometry(
            &ctx.sensor,
            &bench,
            &[idx(names::DBE)?, idx(names::FFT)?, idx(&ring)?],
            config.seed,
            config.odometry_seeds,
            config.odometry_frames,
            progress,
        )?;
        stage("odometry", t);
        rows
    } else {
        Vec::new()
    };

    let t = Instant::now();
    let eval = tables::Evaluation::build(
        config,
        &ctx,
        &bench,
        &sweep_values,
        &single,
        &pairs,
        &noise,
        &scenes,
        odometry,
        timings,
        start,
    )?;
    progress(&format!(
        "   tables: {:.1} s; total {:.1} s",
        t.elapsed().as_secs_f64(),
        eval.wall_time_s
    ));
    Ok(eval)
}
