//! The CSV tables of the report, one per table of [`Evaluation`].

use std::fmt::Write as _;

use super::Evaluation;

fn csv_opt(v: Option<f64>) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x}"),
        _ => String::new(),
    }
}

pub(super) fn csv_files(e: &Evaluation) -> Vec<(&'static str, String)> {
    let mut acc = String::from(
        "snr_db,adc_snr_db,variant,trials,detected,detection_rate,az_rmse_deg,el_rmse_deg,doppler_rmse_mps,az_bias_deg,el_bias_deg,doppler_bias_mps,doppler_scale,crb_az_deg,crb_el_deg,crb_doppler_mps\n",
    );
    for r in &e.accuracy {
        let _ = writeln!(
            acc,
            "{},{:.3},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.snr_db,
            r.adc_snr_db,
            r.variant,
            r.trials,
            r.detected,
            r.detection_rate,
            csv_opt(r.az_rmse_deg),
            csv_opt(r.el_rmse_deg),
            csv_opt(r.doppler_rmse_mps),
            csv_opt(r.az_bias_deg),
            csv_opt(r.el_bias_deg),
            csv_opt(r.doppler_bias_mps),
            csv_opt(r.doppler_scale),
            r.crb_az_deg,
            r.crb_el_deg,
            r.crb_doppler_mps
        );
    }
    let mut res = String::from("pair,separation_deg,snr_db,variant,trials,resolved,probability\n");
    for r in &e.resolution {
        let _ = writeln!(
            res,
            "{},{},{},{},{},{},{}",
            r.pair.name(),
            r.separation_deg,
            r.snr_db,
            r.variant,
            r.trials,
            r.resolved,
            r.probability
        );
    }
    let mut noise = String::from("variant,frames,false_points_per_frame,frames_with_points\n");
    for r in &e.noise {
        let _ = writeln!(
            noise,
            "{},{},{},{}",
            r.variant, r.frames, r.false_points_per_frame, r.frames_with_points
        );
    }
    let mut cd = String::from(
        "scene,resolution_m,variant,frames,empty_frames,chamfer_m,accuracy_m,completeness_m\n",
    );
    for r in &e.chamfer_all {
        let _ = writeln!(
            cd,
            "{},{},{},{},{},{},{},{}",
            r.scene,
            r.resolution_m,
            r.variant,
            r.frames,
            r.empty_frames,
            csv_opt(r.chamfer_m),
            csv_opt(r.accuracy_m),
            csv_opt(r.completeness_m)
        );
    }
    let mut sc = String::from("scene,variant,frames,truth_points_per_frame,points_per_frame,false_points_per_frame,targets,detected,detection_rate,az_rmse_deg,el_rmse_deg,doppler_rmse_mps\n");
    for r in &e.scenes {
        let _ = writeln!(
            sc,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            r.scene,
            r.variant,
            r.frames,
            r.truth_points_per_frame,
            r.points_per_frame,
            r.false_points_per_frame,
            r.targets,
            r.detected,
            csv_opt(r.detection_rate),
            csv_opt(r.az_rmse_deg),
            csv_opt(r.el_rmse_deg),
            csv_opt(r.doppler_rmse_mps)
        );
    }
    let mut d = String::from("parameter,value,is_default,variant");
    for s in &e.config.sweep_snr_db {
        let _ = write!(
            d,
            ",detection_rate_{s}db,az_rmse_deg_{s}db,el_rmse_deg_{s}db"
        );
    }
    for s in &e.config.sweep_separations_deg {
        let _ = write!(d, ",resolve_non_coherent_{s}deg,resolve_coherent_{s}deg");
    }
    d.push_str(",noise_false_points_per_frame,scene_false_points_per_frame,scene_detection_rate,scene_points_per_frame,chamfer_m,chamfer_default_m,chamfer_frames\n");
    for r in &e.defaults {
        let _ = write!(
            d,
            "\"{}\",\"{}\",{},\"{}\"",
            r.parameter, r.value, r.is_default, r.variant
        );
        for i in 0..e.config.sweep_snr_db.len() {
            let _ = write!(
                d,
                ",{},{},{}",
                csv_opt(r.detection_rate.get(i).copied().flatten()),
                csv_opt(r.az_rmse_deg.get(i).copied().flatten()),
                csv_opt(r.el_rmse_deg.get(i).copied().flatten())
            );
        }
        for i in 0..e.config.sweep_separations_deg.len() {
            let _ = write!(
                d,
                ",{},{}",
                csv_opt(r.resolve_non_coherent.get(i).copied().flatten()),
                csv_opt(r.resolve_coherent.get(i).copied().flatten())
            );
        }
        let _ = writeln!(
            d,
            ",{},{},{},{},{},{},{}",
            csv_opt(r.noise_false_points),
            csv_opt(r.scene_false_points),
            csv_opt(r.scene_detection_rate),
            csv_opt(r.scene_points),
            csv_opt(r.chamfer_m),
            csv_opt(r.chamfer_default_m),
            r.chamfer_frames
        );
    }
    let mut odo = String::from("sequence,seed,variant,frames,points_per_frame,ego_rmse_x_mps,ego_rmse_y_mps,ego_rmse_z_mps,estimated_while_moving_pct,updates_applied,updates_gated,point_frames,points_applied,points_gated,path_length_m,ate_rmse_m,drift_xyz_m,drift_xyz_pct,drift_xy_pct,drift_z_pct,drift_yaw_deg,drift_xyz_pct_without_point_updates,drift_xyz_pct_moving_start,zero_rate_updates,drift_xyz_pct_without_zero_rate,drift_xyz_pct_moving_start_without_zero_rate,time_offset_s,drift_xyz_pct_stamp_test_fixed,drift_xyz_pct_stamp_test_estimated,ate_m_stamp_test_fixed,ate_m_stamp_test_estimated,time_offset_stamp_test_s,velocity_scale,drift_xyz_pct_fixed_scale,ate_m_fixed_scale,relative_pct_10,relative_pct_20,relative_pct_30,ego_mean_error_x_mps,ego_mean_error_y_mps,ego_mean_error_z_mps\n");
    for r in &e.odometry {
        let t = r.errors.as_ref();
        let _ = writeln!(
            odo,
            "{},{},{},{},{:.2},{:.4},{:.4},{:.4},{:.1},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4},{:.4},{:.4}",
            r.sequence,
            r.seed,
            r.variant,
            r.frames,
            r.points_per_frame,
            r.ego.rmse_mps[0],
            r.ego.rmse_mps[1],
            r.ego.rmse_mps[2],
            r.ego.estimated_while_moving_pct,
            r.updates.applied,
            r.updates.gated,
            r.updates.point_frames,
            r.updates.points_applied,
            r.updates.points_gated,
            csv_opt(t.map(|t| t.path_length_m)),
            csv_opt(t.map(|t| t.ate_rmse_m)),
            csv_opt(t.map(|t| t.drift.xyz_m)),
            csv_opt(t.map(|t| t.drift.xyz_pct)),
            csv_opt(t.map(|t| t.drift.xy_pct)),
            csv_opt(t.map(|t| t.drift.z_pct)),
            csv_opt(t.map(|t| t.drift.yaw_deg)),
            csv_opt(r.xyz_pct_without_point_updates),
            csv_opt(r.xyz_pct_moving_start),
            r.updates.zero_rate,
            csv_opt(r.xyz_pct_without_zero_rate[0]),
            csv_opt(r.xyz_pct_without_zero_rate[1]),
            csv_opt(r.time_offset_s),
            csv_opt(r.xyz_pct_stamp_test[0]),
            csv_opt(r.xyz_pct_stamp_test[1]),
            csv_opt(r.ate_m_stamp_test[0]),
            csv_opt(r.ate_m_stamp_test[1]),
            csv_opt(r.time_offset_stamp_test_s),
            csv_opt(r.velocity_scale),
            csv_opt(r.fixed_scale[0]),
            csv_opt(r.fixed_scale[1]),
            csv_opt(t.and_then(|t| t.relative.first()).map(|x| x.translation_mean_pct)),
            csv_opt(t.and_then(|t| t.relative.get(1)).map(|x| x.translation_mean_pct)),
            csv_opt(t.and_then(|t| t.relative.get(2)).map(|x| x.translation_mean_pct)),
            r.ego.mean_error_mps[0],
            r.ego.mean_error_mps[1],
            r.ego.mean_error_mps[2],
        );
    }
    vec![
        ("odometry.csv", odo),
        ("accuracy.csv", acc),
        ("resolution.csv", res),
        ("noise_only.csv", noise),
        ("chamfer.csv", cd),
        ("scenes.csv", sc),
        ("defaults.csv", d),
    ]
}
