//! PNG plots: valid files of the documented size, data drawn where the axes say, colours that
//! mean what the scales say, bad input refused without leaving a file.

use std::fs;
use std::path::Path;

use host_sim::cloud::PointRecord;
use host_sim::io::IoError;
use host_sim::plot::{
    doppler_colour, doppler_scale, map_colour, plot_maps, plot_points, Axes, FrameInfo, Map,
    MapAxes, MapsInput, DYNAMIC_RANGE_DB, MAPS_SIZE, MAP_POINT_COLOUR, SIDE_SIZE, TOP_SIZE,
    TRUTH_COLOUR, UNPROCESSED_COLOUR,
};

type TestResult = Result<(), Box<dyn std::error::Error>>;
type Image = (u32, u32, Vec<u8>);

/// Decode an RGB8 PNG: (width, height, pixels).
fn decode(path: &Path) -> Result<Image, Box<dyn std::error::Error>> {
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

fn rgb(img: &Image, (x, y): (u32, u32)) -> [u8; 3] {
    let i = ((y * img.0 + x) * 3) as usize;
    [img.2[i], img.2[i + 1], img.2[i + 2]]
}

/// The pixel of data point `(x, y)`, computed here from the axes' rectangle and ranges as
/// `plotters` maps coordinates (not with `Axes::pixel`).
fn expected_pixel(a: &Axes, x: f64, y: f64) -> (u32, u32) {
    let fx = (x - a.x_range.0) / (a.x_range.1 - a.x_range.0);
    let fy = (y - a.y_range.0) / (a.y_range.1 - a.y_range.0);
    assert!(
        (0.0..=1.0).contains(&fx) && (0.0..=1.0).contains(&fy),
        "({x}, {y}) inside the data area {a:?}"
    );
    let col = (f64::from(a.width - 1) * fx + 1e-3).floor() as u32;
    let row = (f64::from(a.height - 1) * fy + 1e-3).floor() as u32;
    (a.left + col, a.top + a.height - 1 - row)
}

/// Pixels of `img` within `r` pixels of `c` that have colour `colour`.
fn count_near(img: &Image, c: (u32, u32), r: u32, colour: [u8; 3]) -> usize {
    let mut n = 0;
    for y in c.1.saturating_sub(r)..=(c.1 + r).min(img.1 - 1) {
        for x in c.0.saturating_sub(r)..=(c.0 + r).min(img.0 - 1) {
            n += usize::from(rgb(img, (x, y)) == colour);
        }
    }
    n
}

/// The paper's azimuth grid: 188 bins over ±70°.
fn azimuth_grid() -> Vec<f64> {
    use dbe_radar::presets::coloradar as p;
    (0..p::AZIMUTH_BINS)
        .map(|i| p::AZIMUTH_FIRST_DEG + p::AZIMUTH_STEP_DEG * i as f64)
        .collect()
}

fn info() -> FrameInfo {
    FrameInfo {
        source: "corridor".into(),
        frame: 7,
        time_s: 0.7,
        chain: "DBE".into(),
    }
}

fn point(x: f64, y: f64, z: f64, doppler: f64) -> PointRecord {
    PointRecord {
        x,
        y,
        z,
        doppler,
        ..PointRecord::default()
    }
}

const RANGE_BIN_M: f64 = 0.124_906;
const DOPPLER_BIN_MPS: f64 = 0.0397;

/// A ColoRadar-sized frame: a 60 dB range–azimuth peak at (bin 40, azimuth bin 120) and a
/// range–Doppler peak at (bin 40, velocity bin +10), flat floors elsewhere, bins 0..12
/// unprocessed; one point at the peak.
struct Frame {
    ra: Vec<Vec<f32>>,
    rd: Vec<Vec<f32>>,
    az: Vec<f64>,
    vel: Vec<f64>,
    point: PointRecord,
}

fn frame() -> Frame {
    let az = azimuth_grid();
    let vel: Vec<f64> = (0..128)
        .map(|d| (d as f64 - 64.0) * DOPPLER_BIN_MPS)
        .collect();
    let mut ra = vec![vec![1.0f32; az.len()]; 128];
    let mut rd = vec![vec![1.0f32; 128]; 128];
    ra[40][120] = 1e6;
    rd[40][64 + 10] = 1e6;
    for row in ra.iter_mut().chain(rd.iter_mut()).take(12) {
        row.fill(0.0);
    }
    let (r, phi) = (40.0 * RANGE_BIN_M, az[120].to_radians());
    // Azimuth is positive to the right (−y), spec §1.
    let point = point(r * phi.cos(), -r * phi.sin(), 0.0, vel[74]);
    Frame {
        ra,
        rd,
        az,
        vel,
        point,
    }
}

fn draw(path: &Path, f: &Frame) -> Result<MapAxes, IoError> {
    plot_maps(
        path,
        &MapsInput {
            info: &info(),
            range_bin_m: RANGE_BIN_M,
            processed_bins: (12, 125),
            range_azimuth: Map {
                rows: &f.ra,
                columns: &f.az,
            },
            range_doppler: Map {
                rows: &f.rd,
                columns: &f.vel,
            },
            points: std::slice::from_ref(&f.point),
            dynamic_range_db: DYNAMIC_RANGE_DB,
        },
    )
}

#[test]
fn maps_put_each_peak_on_its_cell_and_grey_out_the_unprocessed_band() -> TestResult {
    let f = frame();
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("maps.png");
    let axes = draw(&path, &f)?;
    let img = decode(&path)?;
    assert_eq!((img.0, img.1), MAPS_SIZE);
    let (ra, rd) = (axes.range_azimuth, axes.range_doppler);
    assert!(
        ra.left + ra.width < rd.left,
        "range-azimuth left of range-Doppler"
    );
    assert!(
        rd.left + rd.width < axes.colour_bar.left,
        "colour bar on the right"
    );

    // Cells are centred on their bins: the data areas span half a step beyond the end bins.
    let step = dbe_radar::presets::coloradar::AZIMUTH_STEP_DEG;
    assert!((ra.x_range.0 - (-70.0 - step / 2.0)).abs() < 1e-9);
    assert!((ra.x_range.1 - (70.0 + step / 2.0)).abs() < 1e-9);
    assert!((ra.y_range.0 + RANGE_BIN_M / 2.0).abs() < 1e-12);
    assert!((ra.y_range.1 - 127.5 * RANGE_BIN_M).abs() < 1e-9);
    assert!((rd.x_range.0 - (-64.5 * DOPPLER_BIN_MPS)).abs() < 1e-9);
    assert_eq!(rd.y_range, ra.y_range);

    let (top, bottom) = (map_colour(1.0), map_colour(0.0));
    let r40 = 40.0 * RANGE_BIN_M;
    // The peak cell is the top colour, the cells around it (60 dB down) the bottom colour. A
    // cell is ≈ 3 px wide and 4 px tall; the point's ring (radius 5, 2 px wide) covers the
    // adjacent cells, so the floor is looked at three cells away.
    for (a, x, dx) in [(&ra, f.az[120], step), (&rd, f.vel[74], DOPPLER_BIN_MPS)] {
        assert_eq!(rgb(&img, expected_pixel(a, x, r40)), top, "peak at {x}");
        assert_eq!(
            rgb(&img, expected_pixel(a, x + 3.0 * dx, r40)),
            bottom,
            "three columns away"
        );
        assert_eq!(
            rgb(&img, expected_pixel(a, x, r40 - 3.0 * RANGE_BIN_M)),
            bottom,
            "three range bins closer"
        );
        // Bins 0..12 are not processed: grey, not the bottom of the scale.
        assert_eq!(
            rgb(&img, expected_pixel(a, x + 10.0 * dx, 3.0 * RANGE_BIN_M)),
            UNPROCESSED_COLOUR
        );
        // The point is marked by a ring around the peak.
        let ring = count_near(&img, expected_pixel(a, x, r40), 7, MAP_POINT_COLOUR);
        assert!(ring >= 12, "ring around the point at {x}: {ring} px");
    }
    // Orientation: bin 40 of 128 is in the lower third (range grows upwards), +22.6° azimuth
    // and +0.4 m/s right of centre.
    let (px, py) = expected_pixel(&ra, f.az[120], r40);
    assert!(py > ra.top + ra.height * 3 / 5 && py < ra.top + ra.height * 4 / 5);
    assert!(px > ra.left + ra.width * 3 / 5 && px < ra.left + ra.width * 7 / 10);
    let (qx, _) = expected_pixel(&rd, f.vel[74], r40);
    assert!(qx > rd.left + rd.width / 2);
    // The colour bar runs from the bottom colour (−40 dB) up to the top colour (0 dB), in 200
    // bands: the colour at −0.1 dB is the top band's, within one band's step of the end.
    let bar = axes.colour_bar;
    assert_eq!(bar.y_range, (-40.0, 0.0));
    let close = |a: [u8; 3], b: [u8; 3]| a.iter().zip(b).all(|(&x, y)| x.abs_diff(y) <= 3);
    assert!(close(rgb(&img, expected_pixel(&bar, 0.5, -0.1)), top));
    assert!(close(rgb(&img, expected_pixel(&bar, 0.5, -39.9)), bottom));
    assert!(close(
        rgb(&img, expected_pixel(&bar, 0.5, -20.0)),
        map_colour(0.5)
    ));
    // Text (tick labels) is drawn under the data area.
    let dark = (ra.left..ra.left + ra.width)
        .flat_map(|x| (ra.top + ra.height + 8..ra.top + ra.height + 30).map(move |y| (x, y)))
        .filter(|&p| rgb(&img, p).iter().all(|&c| c < 80))
        .count();
    assert!(dark > 50, "tick labels drawn ({dark} dark pixels)");
    Ok(())
}

#[test]
fn maps_scale_each_map_in_db_below_its_own_maximum() -> TestResult {
    // Three columns at 0, −20 and −40 dB of the map's maximum; the range–Doppler map
    // 10 dB stronger in absolute terms: its colours are the same (exact powers of ten: exact dB).
    let cols = [-10.0, 0.0, 10.0];
    let ra = vec![vec![1e4f32, 1e2, 1.0]; 4];
    let rd = vec![vec![1e5f32, 1e3, 10.0]; 4];
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("maps.png");
    // 0, −20 and −40 dB re each map's maximum: over 40 dB (the default) the top, middle and
    // bottom of the scale; over 80 dB (`dbe plot --dynamic-range-db 80`) its top, ¾ and ½.
    for (range_db, expected) in [
        (DYNAMIC_RANGE_DB, [1.0, 0.5, 0.0]),
        (80.0, [1.0, 0.75, 0.5]),
    ] {
        let axes = plot_maps(
            &path,
            &MapsInput {
                info: &info(),
                range_bin_m: 1.0,
                processed_bins: (0, 3),
                range_azimuth: Map {
                    rows: &ra,
                    columns: &cols,
                },
                range_doppler: Map {
                    rows: &rd,
                    columns: &cols,
                },
                points: &[],
                dynamic_range_db: range_db,
            },
        )?;
        let img = decode(&path)?;
        for a in [&axes.range_azimuth, &axes.range_doppler] {
            let c = |x: f64| rgb(&img, expected_pixel(a, x, 2.0));
            assert_eq!(c(-10.0), map_colour(expected[0]), "{range_db} dB");
            assert_eq!(c(0.0), map_colour(expected[1]), "{range_db} dB");
            assert_eq!(c(10.0), map_colour(expected[2]), "{range_db} dB");
        }
    }
    Ok(())
}

#[test]
fn maps_refuse_bad_input_without_a_file() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("maps.png");
    let cols = [-1.0, 0.0, 1.0];
    let good = vec![vec![1.0f32; 3]; 2];
    let try_maps =
        |ra: &[Vec<f32>], cols_ra: &[f64], rd: &[Vec<f32>], bin: f64, p: &[PointRecord]| {
            plot_maps(
                &path,
                &MapsInput {
                    info: &info(),
                    range_bin_m: bin,
                    processed_bins: (0, 1),
                    range_azimuth: Map {
                        rows: ra,
                        columns: cols_ra,
                    },
                    range_doppler: Map {
                        rows: rd,
                        columns: &cols,
                    },
                    points: p,
                    dynamic_range_db: DYNAMIC_RANGE_DB,
                },
            )
        };
    let nan = vec![vec![1.0f32, f32::NAN, 1.0]; 2];
    let negative = vec![vec![1.0f32, -1.0, 1.0]; 2];
    let ragged = vec![vec![1.0f32; 3], vec![1.0; 2]];
    let cases: Vec<(&str, Result<MapAxes, IoError>)> = vec![
        ("NaN", try_maps(&nan, &cols, &good, 0.1, &[])),
        ("negative", try_maps(&negative, &cols, &good, 0.1, &[])),
        ("ragged", try_maps(&ragged, &cols, &good, 0.1, &[])),
        ("empty", try_maps(&[], &cols, &good, 0.1, &[])),
        (
            "grid order",
            try_maps(&good, &[0.0, -1.0, 1.0], &good, 0.1, &[]),
        ),
        ("range bin", try_maps(&good, &cols, &good, 0.0, &[])),
        (
            "range lengths",
            try_maps(&good, &cols, &good[..1], 0.1, &[]),
        ),
        (
            "point",
            try_maps(&good, &cols, &good, 0.1, &[point(1.0, 0.0, 0.0, f64::NAN)]),
        ),
        (
            "dynamic range",
            plot_maps(
                &path,
                &MapsInput {
                    info: &info(),
                    range_bin_m: 0.1,
                    processed_bins: (0, 1),
                    range_azimuth: Map {
                        rows: &good,
                        columns: &cols,
                    },
                    range_doppler: Map {
                        rows: &good,
                        columns: &cols,
                    },
                    points: &[],
                    dynamic_range_db: 1.0,
                },
            ),
        ),
    ];
    for (what, r) in cases {
        match r {
            Err(e @ IoError::Invalid { .. }) => {
                assert!(e.to_string().contains("maps.png"), "{what}: {e}");
                eprintln!("{what}: {e}");
            }
            other => panic!("{what}: expected Invalid, got {other:?}"),
        }
    }
    assert_eq!(fs::read_dir(dir.path())?.count(), 0, "no file written");
    Ok(())
}

#[test]
fn point_views_colour_points_by_doppler_over_the_truth() -> TestResult {
    let pts = [point(6.0, 2.0, 1.0, -1.2), point(3.0, -1.5, -0.5, 0.0)];
    let truth = [[9.0, -3.0, 0.5], [6.0, 2.0, 1.0]];
    let dir = tempfile::tempdir()?;
    let (top_path, side_path) = (dir.path().join("top.png"), dir.path().join("side.png"));
    let (top, side) = plot_points(&top_path, &side_path, &info(), &pts, Some(&truth))?;
    let top_img = decode(&top_path)?;
    let side_img = decode(&side_path)?;
    assert_eq!((top_img.0, top_img.1), TOP_SIZE);
    assert_eq!((side_img.0, side_img.1), SIDE_SIZE);

    // Equal metres per pixel in the top view; both views share the x range.
    let mx = (top.x_range.1 - top.x_range.0) / f64::from(top.width);
    let my = (top.y_range.1 - top.y_range.0) / f64::from(top.height);
    assert!((mx - my).abs() < 1e-9 * mx, "{mx} vs {my} m/px");
    assert_eq!(top.x_range, side.x_range);

    // Each point's centre pixel has its Doppler colour, also the one drawn on a truth position
    // (points over the truth); the lone truth position is a grey cross.
    let scale = doppler_scale(&pts);
    assert_eq!(scale, 1.5);
    for p in &pts {
        let c = doppler_colour(p.doppler, scale);
        let at = expected_pixel(&top, p.x, p.y);
        assert_eq!(rgb(&top_img, at), c, "top view, point {p:?}");
        let at = expected_pixel(&side, p.x, p.z);
        assert_eq!(rgb(&side_img, at), c, "side view, point {p:?}");
    }
    assert_ne!(
        doppler_colour(-1.2, scale),
        doppler_colour(0.0, scale),
        "a moving point is told from a static one"
    );
    let at = expected_pixel(&top, truth[0][0], truth[0][1]);
    assert_eq!(rgb(&top_img, at), TRUTH_COLOUR, "top view, truth");
    let at = expected_pixel(&side, truth[0][0], truth[0][2]);
    assert_eq!(rgb(&side_img, at), TRUTH_COLOUR, "side view, truth");
    // The cross under the first point shows around it.
    let covered = expected_pixel(&top, 6.0, 2.0);
    assert!(count_near(&top_img, covered, 7, TRUTH_COLOUR) > 0);

    // Orientation, independent of the axes: the point at y = +2 m (left) is drawn above the one
    // at y = −1.5 m, the farther one (x = 6 m) to the right; in the side view z = +1 m is above.
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
    let (top, _) = plot_points(&t, &s, &info(), &[], None)?;
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
    let e = plot_points(&t, &s, &info(), &[point(1.0, f64::NAN, 0.0, 0.0)], None);
    assert!(matches!(e, Err(IoError::Invalid { .. })), "{e:?}");
    let e = plot_points(&t, &s, &info(), &[], Some(&[[1.0, 2.0, f64::INFINITY]]));
    assert!(
        matches!(e, Err(ref err) if err.to_string().contains("truth point 0")),
        "{e:?}"
    );
    assert_eq!(fs::read_dir(dir.path())?.count(), 0);
    Ok(())
}

#[test]
fn titles_name_the_recording_frame_time_and_chain() {
    assert_eq!(
        info().title("top view"),
        "top view \u{2014} corridor, frame 7, t = 0.700 s, DBE chain"
    );
}
