//! README's evaluation figures are the committed report's (`docs/eval/summary.json`, written
//! by `dbe eval --out docs/eval`): regenerating the report without updating README, or editing
//! README's numbers by hand, fails here.

use std::path::Path;

use serde_json::Value;

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn read(relative: &str) -> Result<String, Box<dyn std::error::Error>> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(relative);
    std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()).into())
}

/// `text` with every run of whitespace (line breaks included) as one space: README's
/// sentences wrap.
fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn num(v: &Value, what: &str) -> Result<f64, String> {
    v.as_f64()
        .ok_or_else(|| format!("summary.json: {what} is not a number: {v}"))
}

/// The headline row of `variant` in `headline.single_target_at_20_db`.
fn single<'a>(h: &'a Value, variant: &str) -> Result<&'a Value, String> {
    h["single_target_at_20_db"]
        .as_array()
        .and_then(|a| a.iter().find(|r| r["variant"] == variant))
        .ok_or_else(|| format!("summary.json: no 20 dB row for {variant}"))
}

fn resolved(h: &Value, variant: &str, pair: &str) -> Result<f64, String> {
    let row = h["resolution_at_resolution_snr"]
        .as_array()
        .and_then(|a| {
            a.iter()
                .find(|r| r["variant"] == variant && r["pair"] == pair)
        })
        .ok_or_else(|| format!("summary.json: no {pair} resolution row for {variant}"))?;
    num(&row["probability"], "probability")
}

/// False points per noise-only frame of `variant`, as README prints it.
fn noise(summary: &Value, variant: &str) -> Result<String, String> {
    let row = summary["noise"]
        .as_array()
        .and_then(|a| a.iter().find(|r| r["variant"] == variant))
        .ok_or_else(|| format!("summary.json: no noise row for {variant}"))?;
    let v = num(&row["false_points_per_frame"], "false_points_per_frame")?;
    Ok(if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.2}")
    })
}

/// The Chamfer accuracy term of `variant`: the mean over the extended scenes and every
/// resolution (the goals' definition, `eval::goals`).
fn accuracy_term(summary: &Value, variant: &str) -> Result<f64, String> {
    let v: Vec<f64> = summary["chamfer_all"]
        .as_array()
        .ok_or("summary.json has no chamfer_all")?
        .iter()
        .filter(|r| r["variant"] == variant && r["scene"] != "moving_sensor")
        .filter_map(|r| r["accuracy_m"].as_f64())
        .collect();
    if v.is_empty() {
        return Err(format!("no accuracy term for {variant}"));
    }
    Ok(v.iter().sum::<f64>() / v.len() as f64)
}

/// The paper's CD(τ) on the sequence maps (exact poses, or after ICP), mean over the extended
/// scenes.
fn paper_cd(summary: &Value, tau: f64, key: &str) -> Result<f64, String> {
    let v: Vec<f64> = summary["chamfer_paper"]
        .as_array()
        .ok_or("summary.json has no chamfer_paper")?
        .iter()
        .filter(|r| r["scene"] != "moving_sensor")
        .filter(|r| r["tau"].as_f64().is_some_and(|t| (t - tau).abs() < 1e-9))
        .filter_map(|r| r[key].as_f64())
        .collect();
    if v.len() != host_sim::eval::tables::EXTENDED_SCENES {
        return Err(format!(
            "{} extended scenes with {key} at τ = {tau}",
            v.len()
        ));
    }
    Ok(v.iter().sum::<f64>() / v.len() as f64)
}

#[test]
fn readme_headline_table_is_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let readme = read("README.md")?;
    let h = &summary["headline"];
    let az = |v: &str| -> Result<f64, String> { num(&single(h, v)?["az_rmse_deg"], "az_rmse_deg") };
    let crb = num(&single(h, "dbe")?["crb_az_deg"], "crb_az_deg")?;
    let ext = &h["extended_scenes"];
    let ms = &h["moving_sensor_el_rmse_deg"];
    let pct = |p: f64| format!("{:.0} %", 100.0 * p);
    let lines = [
        format!(
            "| azimuth RMSE at 20 dB per-antenna SNR (CRB {crb:.3}°), sub-grid (default) / `--grid` | {:.3}° / {:.3}° | {:.3}° / {:.3}° |",
            az("dbe")?,
            az("dbe-grid")?,
            az("fft")?,
            az("fft-grid")?
        ),
        format!(
            "| two non-coherent targets 8° apart at 20 dB resolved | {} | {} (by Doppler) |",
            pct(resolved(h, "dbe", "non_coherent")?),
            pct(resolved(h, "fft", "non_coherent")?)
        ),
        format!(
            "| two coherent (static) targets 8° apart at 20 dB resolved | {} | {} |",
            pct(resolved(h, "dbe", "coherent")?),
            pct(resolved(h, "fft", "coherent")?)
        ),
        format!(
            "| moving sensor 1.2 m/s, elevation RMSE, TDM compensation on / off | {:.2}° / {:.1}° | {:.2}° / {:.1}° |",
            num(&ms["dbe"], "dbe")?,
            num(&ms["dbe_no_tdm"], "dbe_no_tdm")?,
            num(&ms["fft"], "fft")?,
            num(&ms["fft_no_tdm"], "fft_no_tdm")?
        ),
        format!(
            "| points per frame on the extended scenes | {:.1} | {:.1} |",
            num(&ext["points_per_frame"]["dbe"], "points")?,
            num(&ext["points_per_frame"]["fft"], "points")?
        ),
        format!(
            "| false points (> 0.6 m from every object) per frame on the extended scenes | {:.2} | {:.2} |",
            num(&ext["false_points_per_frame"]["dbe"], "false points")?,
            num(&ext["false_points_per_frame"]["fft"], "false points")?
        ),
        format!(
            "| mean Chamfer distance at 0.1 m voxels, extended scenes | {:.2} m | {:.2} m |",
            num(&ext["mean_chamfer_m"]["dbe"], "chamfer")?,
            num(&ext["mean_chamfer_m"]["fft"], "chamfer")?
        ),
        format!(
            "| the paper's CD(τ) on sequence maps, τ = 0.2 / 0.05 m, extended scenes | {:.3} m / {:.3} m | {:.3} m / {:.3} m |",
            paper_cd(&summary, 0.2, "dbe")?,
            paper_cd(&summary, 0.05, "dbe")?,
            paper_cd(&summary, 0.2, "fft")?,
            paper_cd(&summary, 0.05, "fft")?
        ),
        format!(
            "| false points per noise-only frame | {} | {} |",
            noise(&summary, "dbe")?,
            noise(&summary, "fft")?
        ),
        format!(
            "| mean distance of a point to the true surfaces (Chamfer accuracy term) | {:.3} m | {:.3} m |",
            accuracy_term(&summary, "dbe")?,
            accuracy_term(&summary, "fft")?
        ),
    ];
    for line in &lines {
        assert!(
            readme.contains(line.as_str()),
            "README lacks the report's line\n{line}"
        );
    }
    Ok(())
}

/// The report's odometry sequences, in its order.
const SEQUENCES: [&str; 4] = ["hallways", "outdoors", "aspen", "army"];

/// Their realistic-surface twins, in the report's order after them.
const TWINS: [&str; 4] = [
    "hallways_realistic",
    "outdoors_realistic",
    "aspen_realistic",
    "army_realistic",
];

/// The odometry summary row of `sequence` and `variant` in the report's `summary.json`.
fn odometry_row<'a>(
    summary: &'a Value,
    sequence: &str,
    variant: &str,
) -> Result<&'a Value, String> {
    summary["odometry_summary"]
        .as_array()
        .ok_or("summary.json has no odometry_summary")?
        .iter()
        .find(|r| r["sequence"] == sequence && r["variant"] == variant)
        .ok_or_else(|| format!("summary.json: no odometry row {sequence} {variant}"))
}

/// One figure of `variant`'s odometry rows for every sequence, `digits` decimals, joined by
/// " / " (README's "hallways / outdoors / aspen / army" lists).
fn odometry_column(
    summary: &Value,
    variant: &str,
    digits: usize,
    f: &dyn Fn(&Value) -> Result<f64, String>,
) -> Result<String, String> {
    sequences_column(&SEQUENCES, summary, variant, digits, f)
}

/// [`odometry_column`] over `sequences`.
fn sequences_column(
    sequences: &[&str],
    summary: &Value,
    variant: &str,
    digits: usize,
    f: &dyn Fn(&Value) -> Result<f64, String>,
) -> Result<String, String> {
    let x: Vec<String> = sequences
        .iter()
        .map(|seq| {
            Ok(format!(
                "{:.digits$}",
                f(odometry_row(summary, seq, variant)?)?
            ))
        })
        .collect::<Result<_, String>>()?;
    Ok(x.join(" / "))
}

#[test]
fn readme_odometry_table_is_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let readme = read("README.md")?;
    let find = |seq: &str, v: &str| odometry_row(&summary, seq, v);
    let seeds = summary["config"]["odometry_seeds"].as_u64().unwrap_or(0);
    assert!(
        readme.contains(&format!("{seeds} seeds each")),
        "README does not say the report's {seeds} seeds"
    );
    for seq in SEQUENCES.into_iter().chain(TWINS) {
        let (d, f) = (find(seq, "dbe")?, find(seq, "fft")?);
        let paired = d["xyz_pct_minus_fft"]
            .as_array()
            .ok_or_else(|| format!("{seq}: no paired difference"))?;
        let ego = |r: &Value| -> Result<String, String> {
            let e = r["ego_rmse_mps"].as_array().ok_or("ego_rmse_mps")?;
            Ok(format!(
                "{:.3}/{:.3}/{:.3}",
                num(&e[0], "x")?,
                num(&e[1], "y")?,
                num(&e[2], "z")?
            ))
        };
        let line = format!(
            "| {seq} | {:.1} | {:.2} | {:.2} | {:+.2} ± {:.2} | {} | {} | {:.1} / {:.1} |",
            num(&d["path_length_m"], "path")?,
            num(&d["drift"]["xyz_pct"], "drift")?,
            num(&f["drift"]["xyz_pct"], "drift")?,
            num(&paired[0], "paired mean")?,
            num(&paired[1], "paired sd")?,
            ego(d)?,
            ego(f)?,
            num(&d["points_per_frame"], "points")?,
            num(&f["points_per_frame"], "points")?,
        );
        assert!(
            readme.contains(&line),
            "README lacks the report's line\n{line}"
        );
    }
    let sigma_z = SEQUENCES
        .iter()
        .map(|seq| {
            let d = find(seq, "dbe")?;
            let (sigma, rmse) = (
                num(&d["ego_predicted_rms_mps"][2], "predicted σ_z")?,
                num(&d["ego_rmse_mps"][2], "RMSE z")?,
            );
            // README: "at or above the RMSE z in the table" (as printed, 3 decimals).
            if (sigma * 1e3).round() < (rmse * 1e3).round() {
                return Err(format!(
                    "{seq}: predicted σ_z {sigma:.3} below RMSE z {rmse:.3}"
                ));
            }
            Ok(format!("{sigma:.3}"))
        })
        .collect::<Result<Vec<_>, String>>()?
        .join(" / ");
    assert!(
        one_line(&readme).contains(&format!(
            "over its estimates, the report's goal row) is {sigma_z} m/s"
        )),
        "README lacks the report's predicted σ_z {sigma_z}"
    );
    // The realistic twins: how many the DBE chain loses, and its drift with the ring split.
    let drift = |r: &Value| num(&r["drift"]["xyz_pct"], "drift");
    let mut above = 0;
    for seq in TWINS {
        above += usize::from(drift(find(seq, "dbe")?)? > drift(find(seq, "fft")?)?);
    }
    let count = ["none", "one", "two", "three", "all"][above];
    let ring = host_sim::eval::sweep_name(&host_sim::eval::SweepValue::RingSplit(true));
    let line = format!(
        "and the DBE chain more than the FFT chain on {count} of the four; with the ring split \
         (`--ring-split`) it drifts {} % on hallways / outdoors / aspen / army against the FFT \
         chain's {} %",
        sequences_column(&TWINS, &summary, &ring, 2, &drift)?,
        sequences_column(&TWINS, &summary, "fft", 2, &drift)?
    );
    assert!(
        one_line(&readme).contains(&line),
        "README lacks the report's\n{line}"
    );
    Ok(())
}

/// README's ring split bullet quotes the report's odometry rows with and without the split.
#[test]
fn readme_ring_split_figures_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let readme = one_line(&read("README.md")?);
    let ring = "dbe[ring split = on]";
    let drift = |r: &Value| num(&r["drift"]["xyz_pct"], "drift");
    let ego_z = |r: &Value| num(&r["ego_rmse_mps"][2], "RMSE z");
    let text = format!(
        "XYZ drift goes from {} % to {} % and its vertical ego-velocity RMSE from {} to {} m/s",
        odometry_column(&summary, "dbe", 2, &drift)?,
        odometry_column(&summary, ring, 2, &drift)?,
        odometry_column(&summary, "dbe", 3, &ego_z)?,
        odometry_column(&summary, ring, 3, &ego_z)?,
    );
    assert!(
        readme.contains(&text),
        "README lacks the report's ring split figures\n{text}"
    );
    Ok(())
}

/// README's sentence on what the DBE map of the outdoor scene lacks names the object with
/// the largest completeness share difference there (`map_objects`) and its figures.
#[test]
fn readme_map_object_figures_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let readme = one_line(&read("README.md")?);
    let scene = "outdoor_poles_walls";
    let diff = |o: &Value| -> Option<f64> {
        Some(o["dbe_share_m"].as_f64()? - o["fft_share_m"].as_f64()?)
    };
    let worst = summary["map_objects"]
        .as_array()
        .ok_or("summary.json has no map_objects")?
        .iter()
        .filter(|o| o["scene"] == scene)
        .filter_map(|o| Some((diff(o)?, o)))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .ok_or(format!("no object rows for {scene}"))?
        .1;
    let text = format!(
        "what the DBE map of {scene} lacks is mostly the {}: {} DBE vs {} FFT map points on it, its \
         samples {:.3} m from the DBE map on average and {:.3} m from the FFT map's",
        worst["object"].as_str().unwrap_or_default(),
        worst["dbe_points"],
        worst["fft_points"],
        num(&worst["dbe_distance_m"], "DBE distance")?,
        num(&worst["fft_distance_m"], "FFT distance")?,
    );
    assert!(
        readme.contains(&text),
        "README lacks the report's per-object figures\n{text}"
    );
    Ok(())
}

/// README's paragraph on the filter's point updates quotes the report's ablation for every
/// row that had any, and its verdict per sequence (less drift than FFT, within the seeds'
/// spread, or more) is the report's.
#[test]
fn readme_point_update_figures_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let flat = one_line(&read("README.md")?);
    let find = |seq: &str, v: &str| odometry_row(&summary, seq, v);
    // README: "changed only the FFT chain's drift (hallways 0.83 to 0.88 %, army …;" and
    // "the DBE chain has an estimate on every moving frame".
    let mut changed = Vec::new();
    for seq in SEQUENCES {
        let dbe = find(seq, "dbe")?;
        assert_eq!(
            num(&dbe["points_applied"], "points")?,
            0.0,
            "{seq}: DBE points"
        );
        let fft = find(seq, "fft")?;
        if num(&fft["points_applied"], "points")? > 0.0 {
            let without = num(&fft["xyz_pct_without_point_updates"], "without")?;
            let with = num(&fft["drift"]["xyz_pct"], "drift")?;
            changed.push(format!("{seq} {without:.2} to {with:.2} %"));
        }
    }
    let line = format!(
        "changed only the FFT chain's drift ({};",
        changed.join(", ")
    );
    assert!(flat.contains(&line), "README lacks the report's {line}");
    // "less than the FFT chain on the open hall (aspen), within the seeds' spread of it on the
    // corridor and the lab (hallways, army), and more on the footpath (outdoors)".
    for (seq, verdict) in [
        ("hallways", Verdict::WithinSpread),
        ("aspen", Verdict::Less),
        ("army", Verdict::WithinSpread),
        ("outdoors", Verdict::More),
    ] {
        let p = find(seq, "dbe")?["xyz_pct_minus_fft"]
            .as_array()
            .ok_or_else(|| format!("{seq}: no paired difference"))?
            .clone();
        let (mean, sd) = (num(&p[0], "mean")?, num(&p[1], "sd")?);
        let holds = match verdict {
            Verdict::Less => mean < -sd,
            Verdict::WithinSpread => mean.abs() <= sd,
            Verdict::More => mean > sd,
        };
        assert!(
            holds,
            "{seq}: DBE − FFT {mean:+.2} ± {sd:.2} is not {verdict:?}"
        );
    }
    // "… read the radar slower in the DBE chain (v_r scale 0.987 against 0.992)".
    let scale = |v: &str| -> Result<f64, String> {
        num(&find("outdoors", v)?["radial_scale"], "radial_scale")
    };
    let (d, f) = (scale("dbe")?, scale("fft")?);
    assert!(d < f, "outdoors: DBE v_r scale {d:.4} not below FFT {f:.4}");
    let line = format!("(v_r scale {d:.3} against {f:.3})");
    assert!(flat.contains(&line), "README lacks the report's {line}");
    // "… read the radar 0.4–2.0 % slower than it moves (DBE 0.980–0.994, FFT 0.986–0.996)".
    let range = |v: &str| -> Result<(f64, f64), String> {
        let mut r = (f64::INFINITY, f64::NEG_INFINITY);
        for seq in SEQUENCES {
            let x = num(&find(seq, v)?["radial_scale"], "radial_scale")?;
            r = (r.0.min(x), r.1.max(x));
        }
        Ok(r)
    };
    let (d, f) = (range("dbe")?, range("fft")?);
    let line = format!(
        "read the radar {:.1}–{:.1} % slower than it moves (DBE {:.3}–{:.3}, FFT {:.3}–{:.3})",
        (1.0 - d.1.max(f.1)) * 100.0,
        (1.0 - d.0.min(f.0)) * 100.0,
        d.0,
        d.1,
        f.0,
        f.1
    );
    assert!(flat.contains(&line), "README lacks the report's {line}");
    Ok(())
}

/// README's sentence on the zero-rate updates quotes the report's ablation: each chain's drift
/// without them, and the DBE chain's started in motion without → with them.
#[test]
fn readme_zero_rate_figures_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let flat = one_line(&read("README.md")?);
    let column =
        |v: &str, f: &dyn Fn(&Value) -> Result<f64, String>| odometry_column(&summary, v, 2, f);
    let without =
        |i: usize| move |r: &Value| num(&r["xyz_pct_without_zero_rate"][i], "without zero rate");
    let line = format!(
        "took the DBE chain's drift from {} % to the table's, the FFT chain's from {} %",
        column("dbe", &without(0))?,
        column("fft", &without(0))?
    );
    assert!(flat.contains(&line), "README lacks the report's {line}");
    let line = format!(
        "took the DBE chain's drift from {} % to {} %)",
        column("dbe", &without(1))?,
        column("dbe", &|r| num(&r["xyz_pct_moving_start"], "moving start"))?
    );
    assert!(flat.contains(&line), "README lacks the report's {line}");
    Ok(())
}

/// README's sentence on the time offset quotes the range of the report's estimates, on the
/// exact stamps and on the stamp test's.
#[test]
fn readme_time_offset_figures_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let flat = one_line(&read("README.md")?);
    let rows = summary["odometry_summary"]
        .as_array()
        .ok_or("summary.json has no odometry_summary")?;
    let range = |key: &str| -> Result<String, String> {
        let mut r = (f64::INFINITY, f64::NEG_INFINITY);
        for row in rows {
            let x = num(&row[key][0], key)? * 1e3;
            r = (r.0.min(x), r.1.max(x));
        }
        Ok(format!("{:.1} … {:.1} ms", r.0, r.1))
    };
    let line = format!(
        "it estimates {}; with every radar velocity stamped 50 ms early, {} (mean over seeds",
        range("time_offset_s")?,
        range("time_offset_stamp_test_s")?
    );
    assert!(flat.contains(&line), "README lacks the report's {line}");
    Ok(())
}

/// README's sentence on the velocity scale quotes the report's estimates (their range), its
/// ablation's ATE per chain, and the footpath's end-point drift with the scale taken as 1 →
/// estimated.
#[test]
fn readme_velocity_scale_figures_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let flat = one_line(&read("README.md")?);
    let column =
        |v: &str, f: &dyn Fn(&Value) -> Result<f64, String>| odometry_column(&summary, v, 3, f);
    let fixed = |i: usize| move |r: &Value| num(&r["fixed_scale"][i], "fixed scale");
    let ate = |r: &Value| num(&r["ate_rmse_m"], "ATE");
    let mut range = (f64::INFINITY, f64::NEG_INFINITY);
    for seq in SEQUENCES {
        for v in ["dbe", "fft"] {
            let k = num(
                &odometry_row(&summary, seq, v)?["velocity_scale"][0],
                "scale",
            )?;
            range = (range.0.min(k), range.1.max(k));
        }
    }
    let outdoors = |v: &str| -> Result<String, String> {
        let r = odometry_row(&summary, "outdoors", v)?;
        Ok(format!(
            "{:.2} to {:.2} %",
            num(&r["fixed_scale"][0], "fixed scale")?,
            num(&r["drift"]["xyz_pct"], "drift")?
        ))
    };
    let line = format!(
        "it estimates {:.3} … {:.3} (DBE and FFT chains, mean over seeds); it took the DBE \
         chain's ATE from {} m to {} m, the FFT chain's from {} m to {} m, and the footpath's \
         end-point drift from {} (DBE) and {} (FFT)",
        range.0,
        range.1,
        column("dbe", &fixed(1))?,
        column("dbe", &ate)?,
        column("fft", &fixed(1))?,
        column("fft", &ate)?,
        outdoors("dbe")?,
        outdoors("fft")?
    );
    assert!(flat.contains(&line), "README lacks the report's {line}");
    Ok(())
}

/// README's sentence on the relative errors quotes the report's (DBE against FFT, 10 / 20 /
/// 30 % of the path) and its verdicts hold: the DBE chain below FFT at every length on aspen
/// and at 20 and 30 % on hallways, above at every length on outdoors and army.
#[test]
fn readme_relative_errors_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let flat = one_line(&read("README.md")?);
    let rel = |seq: &str, v: &str| -> Result<Vec<f64>, String> {
        (0..3)
            .map(|i| {
                num(
                    &odometry_row(&summary, seq, v)?["relative_pct"][i],
                    "relative",
                )
            })
            .collect()
    };
    let text = |x: &[f64]| {
        x.iter()
            .map(|x| format!("{x:.2}"))
            .collect::<Vec<_>>()
            .join("/")
    };
    let mut parts = Vec::new();
    for seq in SEQUENCES {
        let (d, f) = (rel(seq, "dbe")?, rel(seq, "fft")?);
        parts.push(format!("{seq} {} against {}", text(&d), text(&f)));
        let lengths: &[usize] = match seq {
            "hallways" => &[1, 2],
            _ => &[0, 1, 2],
        };
        let ahead = seq == "hallways" || seq == "aspen";
        for &i in lengths {
            assert!(
                (d[i] < f[i]) == ahead,
                "{seq}: relative error DBE {:.2} against FFT {:.2} at length {i}",
                d[i],
                f[i]
            );
        }
    }
    let line = format!("DBE against FFT: {}.", parts.join(", "));
    assert!(flat.contains(&line), "README lacks the report's {line}");
    Ok(())
}

/// README's verdict on one sequence's paired drift difference DBE − FFT.
#[derive(Debug)]
enum Verdict {
    /// Mean below minus one standard deviation.
    Less,
    /// |mean| within one standard deviation over seeds.
    WithinSpread,
    /// Mean above one standard deviation.
    More,
}

/// README's sentence on realistic surfaces names, per comparison, the scenes where the
/// committed report says it holds with them.
#[test]
fn readme_realistic_surface_verdicts_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let readme = read("README.md")?;
    let flat = one_line(&readme);
    let conclusions = summary["surface_conclusions"]
        .as_array()
        .ok_or("summary.json has no surface_conclusions")?;
    let scenes = |claim: &str| -> Result<String, String> {
        let c = conclusions
            .iter()
            .find(|c| c["claim"].as_str().is_some_and(|s| s.starts_with(claim)))
            .ok_or(format!("no conclusion {claim}"))?;
        let names: Vec<&str> = c["realistic"]
            .as_array()
            .ok_or("no realistic list")?
            .iter()
            .filter_map(Value::as_str)
            .collect();
        Ok(names.join(", "))
    };
    let sentence = format!(
        "With realistic surfaces the DBE chain gives at least as many points per frame as the FFT chain on: {}; a lower per-frame Chamfer distance on: {}; no more false points per frame on: {}; an accuracy term ≤ 0.8× the FFT chain's on: {}.",
        scenes("DBE gives at least as many points")?,
        scenes("DBE below FFT in per-frame Chamfer")?,
        scenes("DBE gives no more false points")?,
        scenes("DBE accuracy term")?,
    );
    assert!(
        flat.contains(&sentence),
        "README lacks the report's sentence\n{sentence}"
    );
    Ok(())
}

/// README's angle-accuracy ratios to the Cramér–Rao bound (5–25 dB, DBE chain) are the
/// committed report's.
#[test]
fn readme_crb_ratios_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let readme = read("README.md")?;
    let flat = one_line(&readme);
    let rows: Vec<&Value> = summary["accuracy"]
        .as_array()
        .ok_or("summary.json has no accuracy")?
        .iter()
        .filter(|r| r["variant"] == "dbe")
        .filter(|r| {
            r["snr_db"]
                .as_f64()
                .is_some_and(|s| (5.0..=25.0).contains(&s))
        })
        .collect();
    let range = |rmse: &str, crb: &str| -> Result<(f64, f64), String> {
        let v: Vec<f64> = rows
            .iter()
            .map(|r| Ok(num(&r[rmse], rmse)? / num(&r[crb], crb)?))
            .collect::<Result<_, String>>()?;
        Ok((
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(0.0, f64::max),
        ))
    };
    let (a, e) = (
        range("az_rmse_deg", "crb_az_deg")?,
        range("el_rmse_deg", "crb_el_deg")?,
    );
    for quoted in [
        format!(
            "azimuth {:.2}–{:.2}×, elevation {:.2}–{:.2}× from 5 to 25 dB",
            a.0, a.1, e.0, e.1
        ),
        format!(
            "the azimuth RMSE is {:.2}–{:.2}× the Cramér–Rao bound from 5 to 25 dB",
            a.0, a.1
        ),
    ] {
        assert!(
            flat.contains(&quoted),
            "README lacks the report's figures\n{quoted}"
        );
    }
    Ok(())
}

/// README's Chamfer cell counts (the goals: per frame, and on the sequence maps by the paper's
/// protocol and the symmetric distance) are the committed report's, recounted from its rows.
#[test]
fn readme_chamfer_cell_counts_are_the_committed_report() -> TestResult {
    let summary: Value = serde_json::from_str(&read("docs/eval/summary.json")?)?;
    let flat = one_line(&read("README.md")?);
    // (cells where DBE is below FFT, cells, mean relative difference DBE / FFT − 1 over the
    // cells with both values) over the extended scenes' rows of `key`; a cell without a DBE
    // value (no correspondence) is not below, as the goals count it.
    let count = |key: &str, dbe: &str, fft: &str| -> Result<(usize, usize, f64), String> {
        let rows: Vec<(Option<f64>, Option<f64>)> = summary[key]
            .as_array()
            .ok_or(format!("summary.json has no {key}"))?
            .iter()
            .filter(|r| r["scene"] != "moving_sensor")
            .map(|r| (r[dbe].as_f64(), r[fft].as_f64()))
            .collect();
        let both: Vec<(f64, f64)> = rows.iter().filter_map(|&(d, f)| Some((d?, f?))).collect();
        let wins = both.iter().filter(|(d, f)| d < f).count();
        let rel = both.iter().map(|(d, f)| d / f - 1.0).sum::<f64>() / both.len() as f64;
        Ok((wins, rows.len(), rel))
    };
    let (wins, cells, rel) = count("chamfer", "dbe", "fft")?;
    let sign = if rel < 0.0 { "−" } else { "+" };
    let frame = format!(
        "DBE is below FFT in {wins} of {cells} (scene, resolution) cells, {sign}{:.1} % on average",
        100.0 * rel.abs()
    );
    let (exact, t, _) = count("chamfer_paper", "dbe", "fft")?;
    let (icp, _, _) = count("chamfer_paper", "dbe_icp", "fft_icp")?;
    let (sym, s, _) = count("chamfer_map", "dbe", "fft")?;
    let maps = format!(
        "On the sequence maps DBE is below FFT in {exact} of {t} cells of the paper's CD(τ) with exact poses, {icp} of {t} after ICP, and {sym} of {s} cells of the symmetric distance"
    );
    for sentence in [frame, maps] {
        assert!(
            flat.contains(&sentence),
            "README lacks the report's sentence\n{sentence}"
        );
    }
    Ok(())
}
