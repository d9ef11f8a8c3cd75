//! `dbe plot`: PNGs of one frame's range–azimuth and range–Doppler maps and point cloud.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use host_sim::core_run::{Chain, CoreRunner};
use host_sim::plot::{plot_maps, plot_points, FrameInfo, Map, MapsInput};
use host_sim::sim::FrameTruth;

use super::input::Input;
use super::ParamArgs;

/// Arguments of `dbe plot`.
#[derive(Args, Debug)]
pub struct PlotArgs {
    /// ColoRadar sequence folder or DCA1000 `.bin` capture.
    pub input: PathBuf,
    /// Frame index.
    #[arg(long, default_value_t = 0)]
    pub frame: usize,
    /// Calibration folder (as for `dbe process`).
    #[arg(long)]
    pub calib: Option<PathBuf>,
    /// The TI board whose antenna layout a TI `.cfg` given as `--calib` runs on.
    #[arg(long, value_enum)]
    pub board: Option<host_sim::io::ticfg::Board>,
    /// Output folder for the PNGs (created if missing; files are replaced atomically).
    #[arg(long)]
    pub out: PathBuf,
    /// Colour scale of the maps: dB below each map's maximum, 3 to 200 (more shows weak
    /// returns beside a strong reflector).
    #[arg(long, value_name = "DB", default_value_t = host_sim::plot::DYNAMIC_RANGE_DB)]
    pub dynamic_range_db: f64,
    #[command(flatten)]
    pub params: ParamArgs,
}

/// Ground-truth points of frame `i` of a simulated sequence (`<seq>/groundtruth/`), if any:
/// visible point targets and sampled visible surfaces.
pub fn truth_points(seq: Option<&Path>, i: usize) -> Result<Option<Vec<[f64; 3]>>> {
    let Some(path) = seq.map(|s| s.join(format!("groundtruth/frame_{i}.json"))) else {
        return Ok(None);
    };
    if !path.is_file() {
        return Ok(None);
    }
    let text = fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let truth: FrameTruth =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let mut pts = Vec::new();
    for o in truth.objects.iter().filter(|o| o.visible) {
        if o.surface_points.is_empty() {
            pts.push(o.position);
        } else {
            pts.extend_from_slice(&o.surface_points);
        }
    }
    Ok(Some(pts))
}

/// Plot frame `i` of `input` into `out`: `maps_<i>.png` (the DBE chain's range–azimuth map
/// beside the FFT chain's range–Doppler map, the DBE points marked on both),
/// `points_top_<i>.png` and `points_side_<i>.png`, the maps over `dynamic_range_db`; returns
/// the files written.
pub fn plot_frame(
    input: &Input,
    sensor: &host_sim::sensor::SensorConfig,
    params: &dbe_radar::Params,
    i: usize,
    out: &Path,
    dynamic_range_db: f64,
) -> Result<Vec<PathBuf>> {
    let frame = input.frame(i)?;
    let dbe = CoreRunner::new(sensor, *params)?.process(&frame)?;
    let fft = CoreRunner::with_chain(sensor, *params, Chain::Fft)?.process(&frame)?;
    fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let (a0, a1) = params.azimuth_span_deg;
    let naz = dbe.ra_map.first().map_or(0, Vec::len);
    let az: Vec<f64> = (0..naz)
        .map(|k| f64::from(a0) + f64::from(a1 - a0) * k as f64 / (naz.max(2) - 1) as f64)
        .collect();
    // The range–Doppler rows in natural FFT order, shifted so that velocity increases.
    let k = sensor.loops;
    let dv = sensor
        .waveform
        .doppler_bin_mps(sensor.samples, sensor.loops, sensor.num_tx);
    let velocity: Vec<f64> = (0..k).map(|d| (d as f64 - (k / 2) as f64) * dv).collect();
    let rd: Vec<Vec<f32>> = fft
        .rd_map
        .iter()
        .map(|row| (0..k).map(|d| row[(d + k - k / 2) % k]).collect())
        .collect();
    let info = FrameInfo {
        source: input.name(),
        frame: i,
        time_s: input.time(i),
        chain: "DBE".into(),
    };
    let maps = out.join(format!("maps_{i}.png"));
    plot_maps(
        &maps,
        &MapsInput {
            info: &info,
            range_bin_m: sensor.waveform.range_bin_m(sensor.samples),
            processed_bins: (
                usize::from(params.range_first),
                usize::from(params.range_last),
            ),
            range_azimuth: Map {
                rows: &dbe.ra_map,
                columns: &az,
            },
            range_doppler: Map {
                rows: &rd,
                columns: &velocity,
            },
            points: &dbe.points,
            dynamic_range_db,
        },
    )?;
    let (top, side) = (
        out.join(format!("points_top_{i}.png")),
        out.join(format!("points_side_{i}.png")),
    );
    let truth = truth_points(input.sequence_dir(), i)?;
    plot_points(&top, &side, &info, &dbe.points, truth.as_deref())?;
    Ok(vec![maps, top, side])
}

/// `dbe plot`.
pub fn run(args: &PlotArgs) -> Result<()> {
    // Checked before anything is opened or written (`plot_maps` refuses it too, later).
    let (range, allowed) = (args.dynamic_range_db, host_sim::plot::DYNAMIC_RANGES_DB);
    if !allowed.contains(&range) {
        anyhow::bail!(
            "--dynamic-range-db {range}: expected {} to {} dB",
            allowed.start(),
            allowed.end()
        );
    }
    let opened = Input::open(&args.input, args.calib.as_deref(), args.board)?;
    if args.frame >= opened.input.len() {
        anyhow::bail!(
            "--frame {}: the input has frames 0..{}",
            args.frame,
            opened.input.len()
        );
    }
    let params = args.params.to_params(&opened.sensor)?;
    for f in plot_frame(
        &opened.input,
        &opened.sensor,
        &params,
        args.frame,
        &args.out,
        args.dynamic_range_db,
    )? {
        outln!("{}", f.display())?;
    }
    Ok(())
}
