//! PNG plots: valid files of the documented size, data drawn where the axes say, bad input
//! refused without leaving a file.

use std::fs;
use std::path::Path;

use host_sim::cloud::PointRecord;
use host_sim::io::IoError;
use host_sim::plot::{
    plot_points, plot_range_azimuth, Axes, POINT_COLOUR, RA_BOTTOM_COLOUR, RA_SIZE, RA_TOP_COLOUR,
    SIDE_SIZE, TOP_SIZE, TRUTH_COLOUR,
};

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// Decode an RGB8 PNG: (width, height, pixels).
fn decode(path: &Path) -> Result<(u32, u32, Vec<u8>), Box<dyn std::error::Error>> {
    let bytes = fs::read(path)?;
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info()?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf)?;
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    buf.truncate(info.buffer_size());
    Ok((info.width, info.height, buf))
}

fn rgb(img: &(u32, u32, Vec<u8>), x: u32, y: u32) -> [u8; 3] {
    let i = ((y * img.0 + x) * 3) as usize;
    [img.2[i], img.2[i + 1], img.2[i + 2]]
}

/// The pixel of data point `(x, y)`, computed here from the axes' rectangle and ranges (not
/// with `Axes::pixel`), rounding to the pixel whose centre is nearest.
fn expected_pixel(a: &Axes, x: f64, y: f64) -> (u32, u32) {
    let fx = (x - a.x_range.0) / (a.x_range.1 - a.x_range.0);
    let fy = (a.y_range.1 - y) / (a.y_range.1 - a.y_range.0);
    assert!(
        (0.0..1.0).contains(&fx) && (0.0..1.0).contains(&fy),
        "inside the data area"
    );
    (
        a.left + (fx * f64::from(a.width)).floor() as u32,
        a.top + (fy * f64::from(a.height)).floor() as u32,
    )
}

/// The paper's azimuth grid: 188 bins over ±70°.
fn azimuth_grid() -> Vec<f64> {
    use dbe_radar::presets::coloradar as p;
    (0..p::AZIMUTH_BINS)
        .map(|i| p::AZIMUTH_FIRST_DEG + p::AZIMUTH_STEP_DEG * i as f64)
        .collect()
}

#[test]
fn range_azimuth_heatmap_puts_the_peak_on_its_cell() -> TestResult {
    let grid = azimuth_grid();
    let (peak_b, peak_i) = (40usize, 120usize);
    // f32 rows as the core's Workspace gives them: 60 dB peak over a flat floor.
    let mut map = vec![[1.0f32; 188]; 128];
    map[peak_b][peak_i] = 1e6;
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("ra.png");
    let range_bin_m = 0.124_906;
    let axes = plot_range_azimuth(&path, &map, range_bin_m, &grid)?;
    let img = decode(&path)?;
    assert_eq!((img.0, img.1), RA_SIZE);

    // Cells are centred on their bins: the data area spans half a step beyond the end bins.
    let step = dbe_radar::presets::coloradar::AZIMUTH_STEP_DEG;
    assert!((axes.x_range.0 - (-70.0 - step / 2.0)).abs() < 1e-9);
    assert!((axes.x_range.1 - (70.0 + step / 2.0)).abs() < 1e-9);
    assert!((axes.y_range.0 + range_bin_m / 2.0).abs() < 1e-12);
    assert!((axes.y_range.1 - 127.5 * range_bin_m).abs() < 1e-9);

    // One cell is 560/188 ≈ 3 px wide and 460/128 ≈ 3.6 px tall: its centre pixel and the
    // pixels one cell away tell the peak from the floor.
    let (px, py) = expected_pixel(&axes, grid[peak_i], peak_b as f64 * range_bin_m);
    assert_eq!(
        rgb(&img, px, py),
        RA_TOP_COLOUR,
        "peak cell at ({px}, {py})"
    );
    let (qx, qy) = expected_pixel(&axes, grid[peak_i + 1], peak_b as f64 * range_bin_m);
    assert_eq!(
        rgb(&img, qx, qy),
        RA_BOTTOM_COLOUR,
        "next azimuth cell is 60 dB down"
    );
    let (rx, ry) = expected_pixel(&axes, grid[peak_i], (peak_b + 1) as f64 * range_bin_m);
    assert_eq!(
        rgb(&img, rx, ry),
        RA_BOTTOM_COLOUR,
        "next range cell is 60 dB down"
    );
    // Orientation: bin 40 of 128 is in the lower third (range grows upwards), +22.6° azimuth
    // right of centre.
    assert!(py > axes.top + axes.height * 3 / 5 && py < axes.top + axes.height * 4 / 5);
    assert!(px > axes.left + axes.width * 3 / 5 && px < axes.left + axes.width * 7 / 10);
    // Something (tick labels) is drawn in black under the data area.
    let below = (axes.left..axes.left + axes.width)
        .flat_map(|x| {
            (axes.top + axes.height + 10..axes.top + axes.height + 30).map(move |y| (x, y))
        })
        .filter(|&(x, y)| rgb(&img, x, y) == [0, 0, 0])
        .count();
    assert!(below > 50, "tick labels drawn ({below} black pixels)");
    Ok(())
}

#[test]
fn range_azimuth_accepts_f64_vec_rows_and_scales_in_db() -> TestResult {
    // Three azimuth bins: 0 dB, −20 dB, −40 dB relative to the maximum.
    let grid = [-10.0, 0.0, 10.0];
    let map = vec![vec![100.0f64, 1.0, 0.01]; 4];
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("ra.png");
    let axes = plot_range_azimuth(&path, &map, 1.0, &grid)?;
    let img = decode(&path)?;
    let c = |az: f64| {
        let (x, y) = expected_pixel(&axes, az, 2.0);
        rgb(&img, x, y)
    };
    assert_eq!(c(-10.0), RA_TOP_COLOUR);
    assert_eq!(c(10.0), RA_BOTTOM_COLOUR);
    // −20 dB is half way on the 40 dB scale: viridis(0.5) = (33, 144, 141).
    assert_eq!(c(0.0), [33, 144, 141]);
    Ok(())
}

#[test]
fn range_azimuth_bad_input_is_refused_without_a_file() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("ra.png");
    let grid = [-1.0, 0.0, 1.0];
    let cases: Vec<(&str, Result<Axes, IoError>)> = vec![
        (
            "NaN",
            plot_range_azimuth(&path, &[vec![1.0f32, f32::NAN, 1.0]], 0.1, &grid),
        ),
        (
            "negative",
            plot_range_azimuth(&path, &[vec![1.0f32, -1.0, 1.0]], 0.1, &grid),
        ),
        (
            "ragged",
            plot_range_azimuth(&path, &[vec![1.0f32; 3], vec![1.0; 2]], 0.1, &grid),
        ),
        (
            "empty",
            plot_range_azimuth::<Vec<f32>, f32>(&path, &[], 0.1, &grid),
        ),
        (
            "grid order",
            plot_range_azimuth(&path, &[vec![1.0f32; 3]], 0.1, &[0.0, -1.0, 1.0]),
        ),
        (
            "range bin",
            plot_range_azimuth(&path, &[vec![1.0f32; 3]], 0.0, &grid),
        ),
    ];
    for (what, r) in cases {
        match r {
            Err(e @ IoError::Invalid { .. }) => {
                assert!(e.to_string().contains("ra.png"), "{what}: {e}");
                eprintln!("{what}: {e}");
            }
            other => panic!("{what}: expected Invalid, got {other:?}"),
        }
    }
    assert_eq!(fs::read_dir(dir.path())?.count(), 0, "no file written");
    Ok(())
}

fn point(x: f64, y: f64, z: f64) -> PointRecord {
    PointRecord {
        x,
        y,
        z,
        ..PointRecord::default()
    }
}

#[test]
fn point_views_put_points_and_truth_where_they_belong() -> TestResult {
    let pts = [point(6.0, 2.0, 1.0), point(3.0, -1.5, -0.5)];
    let truth = [[9.0, -3.0, 0.5]];
    let dir = tempfile::tempdir()?;
    let (top_path, side_path) = (dir.path().join("top.png"), dir.path().join("side.png"));
    let (top, side) = plot_points(&top_path, &side_path, &pts, Some(&truth))?;
    let top_img = decode(&top_path)?;
    let side_img = decode(&side_path)?;
    assert_eq!((top_img.0, top_img.1), TOP_SIZE);
    assert_eq!((side_img.0, side_img.1), SIDE_SIZE);

    // Equal metres per pixel in the top view; both views share the x range.
    let mx = (top.x_range.1 - top.x_range.0) / f64::from(top.width);
    let my = (top.y_range.1 - top.y_range.0) / f64::from(top.height);
    assert!((mx - my).abs() < 1e-9 * mx, "{mx} vs {my} m/px");
    assert_eq!(top.x_range, side.x_range);

    for p in &pts {
        let (x, y) = expected_pixel(&top, p.x, p.y);
        assert_eq!(rgb(&top_img, x, y), POINT_COLOUR, "top view, point {p:?}");
        let (x, z) = expected_pixel(&side, p.x, p.z);
        assert_eq!(rgb(&side_img, x, z), POINT_COLOUR, "side view, point {p:?}");
    }
    let (x, y) = expected_pixel(&top, truth[0][0], truth[0][1]);
    assert_eq!(rgb(&top_img, x, y), TRUTH_COLOUR, "top view, truth");
    let (x, z) = expected_pixel(&side, truth[0][0], truth[0][2]);
    assert_eq!(rgb(&side_img, x, z), TRUTH_COLOUR, "side view, truth");

    // Orientation, independent of the axes: the point at y = +2 m (left) is drawn above the one
    // at y = −1.5 m, the farther one (x = 6 m) to the right; in the side view z = +1 m is above.
    let count_at = |img: &(u32, u32, Vec<u8>), c: [u8; 3]| {
        let mut v = Vec::new();
        for yy in 0..img.1 {
            for xx in 0..img.0 {
                if rgb(img, xx, yy) == c {
                    v.push((xx, yy));
                }
            }
        }
        v
    };
    let red = count_at(&top_img, POINT_COLOUR);
    // Two 5 × 5 squares + the 8 × 8 legend swatch.
    assert_eq!(red.len(), 2 * 25 + 64);
    let (p0, p1) = (
        expected_pixel(&top, 6.0, 2.0),
        expected_pixel(&top, 3.0, -1.5),
    );
    assert!(p0.0 > p1.0 && p0.1 < p1.1);
    let (s0, s1) = (
        expected_pixel(&side, 6.0, 1.0),
        expected_pixel(&side, 3.0, -0.5),
    );
    assert!(s0.0 > s1.0 && s0.1 < s1.1);
    // 1 m of y in the top view spans as many pixels as 1 m of x.
    let dx = f64::from(p0.0 - p1.0) / 3.0;
    let dy = f64::from(p1.1 - p0.1) / 3.5;
    assert!((dx - dy).abs() <= 1.0, "{dx} vs {dy} px/m");
    Ok(())
}

#[test]
fn point_views_without_points_still_draw_axes() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (t, s) = (dir.path().join("t.png"), dir.path().join("s.png"));
    let (top, _) = plot_points(&t, &s, &[], None)?;
    assert!(
        top.x_range.0 < 0.0 && top.x_range.1 > 0.0,
        "radar origin shown"
    );
    assert_eq!(decode(&t)?.0, TOP_SIZE.0);
    assert_eq!(decode(&s)?.1, SIDE_SIZE.1);
    Ok(())
}

#[test]
fn point_views_refuse_nan_without_a_file() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (t, s) = (dir.path().join("t.png"), dir.path().join("s.png"));
    let e = plot_points(&t, &s, &[point(1.0, f64::NAN, 0.0)], None);
    assert!(matches!(e, Err(IoError::Invalid { .. })), "{e:?}");
    let e = plot_points(&t, &s, &[], Some(&[[1.0, 2.0, f64::INFINITY]]));
    assert!(
        matches!(e, Err(ref err) if err.to_string().contains("truth point 0")),
        "{e:?}"
    );
    assert_eq!(fs::read_dir(dir.path())?.count(), 0);
    Ok(())
}
