//! The report's charts (RMSE against SNR beside the bound, resolution against separation, …),
//! built from the tables of [`Evaluation`] and drawn by [`super::chart`].

use super::chart::{Chart, Series, PALETTE};
use super::report::doppler_bin_mps;
use super::scenarios::{Pair, SCENES};
use super::tables::{AZIMUTH_STEP_DEG, ELEVATION_STEP_DEG};
use super::{names, Evaluation};

/// Series of one accuracy column over SNR for `variant`.
fn over_snr(
    e: &Evaluation,
    variant: &str,
    get: impl Fn(&super::tables::AccuracyRow) -> Option<f64>,
) -> Vec<(f64, f64)> {
    e.accuracy
        .iter()
        .filter(|r| r.variant == variant)
        .map(|r| (r.snr_db, get(r).unwrap_or(f64::NAN)))
        .collect()
}

fn series(label: &str, points: Vec<(f64, f64)>, colour: usize, dashed: bool) -> Series {
    Series {
        label: label.to_string(),
        points,
        colour: PALETTE[colour % PALETTE.len()],
        dashed,
    }
}

/// One RMSE-vs-SNR chart: a column of the accuracy table, its bound and its grid floor.
struct RmseChart {
    file: &'static str,
    title: &'static str,
    y: &'static str,
    get: fn(&super::tables::AccuracyRow) -> Option<f64>,
    crb: fn(&super::tables::AccuracyRow) -> Option<f64>,
    floor: f64,
}

pub(super) fn charts(e: &Evaluation) -> Vec<(String, Chart)> {
    let mut out = Vec::new();
    let main = [names::DBE, names::FFT, names::DBE_GRID, names::FFT_GRID];
    let snr_lo = e.config.snr_db.first().copied().unwrap_or(0.0);
    let snr_hi = e.config.snr_db.last().copied().unwrap_or(0.0);
    let specs: [RmseChart; 3] = [
        RmseChart {
            file: "azimuth_rmse.png",
            title: "Azimuth RMSE vs SNR, one target",
            y: "azimuth RMSE (deg)",
            get: |r| r.az_rmse_deg,
            crb: |r| Some(r.crb_az_deg),
            floor: AZIMUTH_STEP_DEG / 12f64.sqrt(),
        },
        RmseChart {
            file: "elevation_rmse.png",
            title: "Elevation RMSE vs SNR, one target",
            y: "elevation RMSE (deg)",
            get: |r| r.el_rmse_deg,
            crb: |r| Some(r.crb_el_deg),
            floor: ELEVATION_STEP_DEG / 12f64.sqrt(),
        },
        RmseChart {
            file: "doppler_rmse.png",
            title: "Radial-velocity RMSE vs SNR, one target",
            y: "velocity RMSE (m/s)",
            get: |r| r.doppler_rmse_mps,
            crb: |r| Some(r.crb_doppler_mps),
            floor: doppler_bin_mps() / 12f64.sqrt(),
        },
    ];
    for c in specs {
        let mut s: Vec<Series> = main
            .iter()
            .enumerate()
            .map(|(i, v)| series(v, over_snr(e, v, c.get), i, false))
            .collect();
        s.push(series("CRB", over_snr(e, names::DBE, c.crb), 6, true));
        s.push(series(
            "grid floor",
            vec![(snr_lo, c.floor), (snr_hi, c.floor)],
            7,
            true,
        ));
        out.push((
            c.file.to_string(),
            Chart {
                title: c.title.to_string(),
                x_label: "SNR per antenna after range FFT (dB)".into(),
                y_label: c.y.to_string(),
                log_x: false,
                log_y: true,
                y_range: None,
                equal_aspect: false,
                series: s,
            },
        ));
    }
    let det = [names::DBE, names::FFT, names::DBE_NO_TDM, names::FFT_NO_TDM];
    out.push((
        "detection_rate.png".into(),
        Chart {
            title: "Detection rate of one target vs SNR".into(),
            x_label: "SNR per antenna after range FFT (dB)".into(),
            y_label: "detection rate".into(),
            log_x: false,
            log_y: false,
            y_range: Some((0.0, 1.0)),
            equal_aspect: false,
            series: det
                .iter()
                .enumerate()
                .map(|(i, v)| series(v, over_snr(e, v, |r| Some(r.detection_rate)), i, false))
                .collect(),
        },
    ));
    let mut res = Vec::new();
    for (i, (v, pair)) in [
        (names::DBE, Pair::NonCoherent),
        (names::DBE, Pair::Coherent),
        (names::FFT, Pair::NonCoherent),
        (names::FFT, Pair::Coherent),
    ]
    .into_iter()
    .enumerate()
    {
        let pts = e
            .resolution
            .iter()
            .filter(|r| {
                r.variant == v
                    && r.pair == pair
                    && (r.snr_db - e.config.resolution_snr_db).abs() < 1e-9
            })
            .map(|r| (r.separation_deg, r.probability))
            .collect();
        res.push(series(&format!("{v} {}", pair.name()), pts, i, false));
    }
    out.push((
        "resolution.png".into(),
        Chart {
            title: format!(
                "Two equal targets at {} dB: P(resolved)",
                e.config.resolution_snr_db
            ),
            x_label: "azimuth separation (deg)".into(),
            y_label: "probability resolved".into(),
            log_x: false,
            log_y: false,
            y_range: Some((0.0, 1.0)),
            equal_aspect: false,
            series: res,
        },
    ));
    for scene in SCENES.iter().map(|s| s.name) {
        let s: Vec<Series> = main
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let pts = e
                    .chamfer_all
                    .iter()
                    .filter(|r| r.scene == scene && r.variant == *v)
                    .map(|r| (r.resolution_m, r.chamfer_m.unwrap_or(f64::NAN)))
                    .collect();
                series(v, pts, i, false)
            })
            .collect();
        out.push((
            format!("chamfer_{scene}.png"),
            Chart {
                title: format!("Chamfer distance per frame, {scene}"),
                x_label: "voxel size (m)".into(),
                y_label: "Chamfer distance (m)".into(),
                log_x: true,
                log_y: false,
                y_range: None,
                equal_aspect: false,
                series: s,
            },
        ));
    }
    out
}
