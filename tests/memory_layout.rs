//! Pins the buffer sizes published in memory-layout.md: a change of any buffer breaks this
//! test until the document is updated with it.

use core::mem::size_of;
use dbe_radar::cfar::{Detection, MAX_TRAINING_CELLS};
use dbe_radar::{presets, Complex32, Point};

/// Bytes of one `usize` field (4 on Cortex-M, 8 on a 64-bit host), for the few small
/// length fields whose size depends on the target.
const W: usize = size_of::<usize>();

fn round8(x: usize) -> usize {
    x.div_ceil(8) * 8
}

#[test]
fn element_sizes() {
    assert_eq!(size_of::<Complex32>(), 8);
    assert_eq!(size_of::<dbe_radar::cube::CubeSample>(), 4);
    assert_eq!(size_of::<Detection>(), 12);
    assert_eq!(size_of::<Point>(), 32);
}

#[test]
fn coloradar_buffers() {
    use presets::coloradar as p;
    // Cube: N · M · K complex i16 mantissas; the cube's bookkeeping (exponents M·K, counters).
    assert_eq!(size_of::<p::CubeStorage>(), 128 * 12 * 128 * 4);
    assert_eq!(size_of::<p::CubeStorage>(), 786_432);
    assert_eq!(size_of::<p::Cube<'_>>(), round8(W + 12 * 128 + 16));
    // Workspace: bin in flight M·K·8 + RA map N·NAZ·4 + loading floor N·4
    //            + CFAR scratch 1024·4 + detections DET·12 (+ length and overflow count).
    let ws = 12 * 128 * 8 + 128 * 188 * 4 + 128 * 4 + MAX_TRAINING_CELLS * 4 + 128 * 12;
    assert_eq!(ws, 114_688);
    // (the detection list with its length and overflow count, padded to 8; the skipped-bin
    // count; the beam Doppler of each detection, DET·4, for the coherence test)
    let list = round8(128 * 12 + W + 4);
    assert_eq!(
        size_of::<p::Workspace>(),
        round8(ws - 128 * 12 + list + 4 + 128 * 4)
    );
    // Points: P · 32 + length + 7 statistics counters.
    assert_eq!(size_of::<p::PointCloud>(), round8(256 * 32 + W + 28));
    // Frontend: optional coupling table M·N·8, range window N·4, channel gains M·8, and small
    // configuration (waveform, geometry, array layout).
    let frontend_tables = 12 * 128 * 8 + 128 * 4 + 12 * 8;
    assert_eq!(frontend_tables, 12_896);
    let frontend = size_of::<p::Frontend>();
    assert!(
        frontend >= frontend_tables && frontend <= frontend_tables + 512,
        "Frontend is {frontend} bytes"
    );
    // Configured chain: steering tables NAZ·M·8 + NEL·M·8, the azimuth line phases NAZ·8,
    // the coherent split's start AZ·8, Doppler window K·4, grids (NAZ + NEL)·4, and small
    // configuration.
    let tables = 188 * 12 * 8 + 101 * 12 * 8 + 188 * 8 + 8 * 8 + 128 * 4 + (188 + 101) * 4;
    assert_eq!(tables, 30_980);
    let dbe = size_of::<p::Dbe>();
    assert!(dbe >= tables && dbe <= tables + 512, "Dbe is {dbe} bytes");
    // Ego-velocity: DET directions (12) + velocities (4) + inverse ranges (4) + inlier
    // flags (1) + median scratch (4), parameters and iteration count.
    assert_eq!(size_of::<p::EgoEstimator>(), 128 * 25 + 64);
}

#[test]
fn iwr6843_buffers() {
    use presets::iwr6843 as p;
    assert_eq!(size_of::<p::CubeStorage>(), 256 * 12 * 64 * 4);
    assert_eq!(size_of::<p::CubeStorage>(), 786_432);
    assert_eq!(size_of::<p::Cube<'_>>(), round8(W + 12 * 64 + 16));
    let ws = 12 * 64 * 8 + 256 * 188 * 4 + 256 * 4 + MAX_TRAINING_CELLS * 4 + 128 * 12;
    assert_eq!(ws, 205_312);
    let list = round8(128 * 12 + W + 4);
    assert_eq!(
        size_of::<p::Workspace>(),
        round8(ws - 128 * 12 + list + 4 + 128 * 4)
    );
    assert_eq!(size_of::<p::PointCloud>(), round8(256 * 32 + W + 28));
    let frontend_tables = 12 * 256 * 8 + 256 * 4 + 12 * 8;
    assert_eq!(frontend_tables, 25_696);
    let frontend = size_of::<p::Frontend>();
    assert!(frontend >= frontend_tables && frontend <= frontend_tables + 512);
    let tables = 188 * 12 * 8 + 101 * 12 * 8 + 188 * 8 + 8 * 8 + 64 * 4 + (188 + 101) * 4;
    assert_eq!(tables, 30_724);
    let dbe = size_of::<p::Dbe>();
    assert!(dbe >= tables && dbe <= tables + 512, "Dbe is {dbe} bytes");
}

/// One row of memory-layout.md's table of every compiled frame size: the 64-bit host sizes
/// of the buffers of `(samples, loops, TX)` with the ColoRadar preset's grids and capacities.
fn preset_rows() -> Vec<String> {
    use presets::coloradar::{AZIMUTH_BINS as NAZ, DETECTIONS as DET, ELEVATION_BINS as NEL};
    use presets::coloradar::{POINTS as P, RX};
    fn n(x: usize) -> String {
        let s = x.to_string();
        let mut out = String::new();
        for (i, c) in s.chars().enumerate() {
            if i > 0 && (s.len() - i) % 3 == 0 {
                out.push(',');
            }
            out.push(c);
        }
        out
    }
    macro_rules! rows {
        ($(($n:literal, $k:literal, $tx:literal))*) => {
            vec![$({
                const M: usize = $tx * RX;
                let cube = size_of::<dbe_radar::cube::CubeStorage<$n, $k, M>>()
                    + size_of::<dbe_radar::Cube<'_, $n, $k, M>>();
                let frontend = size_of::<dbe_radar::Frontend<$n, $k, $tx, RX, M, 8>>();
                let work = size_of::<dbe_radar::Workspace<$n, $k, M, NAZ, DET>>();
                let dbe = size_of::<dbe_radar::Dbe<$n, $k, $tx, RX, M, 8, NAZ, NEL, DET>>();
                let fft_work = size_of::<dbe_radar::FftWorkspace<$n, $k, M, DET>>();
                let fft = size_of::<dbe_radar::FftChain<$n, $k, $tx, RX, M, 8, NAZ, NEL, DET>>();
                let common = cube + frontend + size_of::<dbe_radar::PointCloud<P>>()
                    + size_of::<dbe_radar::EgoEstimator<DET>>();
                format!(
                    "| {} × {} | {} | {} | {} | {} | {} | **{}** | {} | {} | **{}** |",
                    $n, $k, $tx, n(cube), n(frontend), n(work), n(dbe),
                    n(common + work + dbe), n(fft_work), n(fft), n(common + fft_work + fft)
                )
            }),*]
        };
    }
    dbe_radar::ti_frame_sizes!(rows)
}

#[test]
fn memory_layout_lists_every_compiled_frame_size() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/memory-layout.md");
    let doc = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let missing: Vec<String> = preset_rows()
        .into_iter()
        .filter(|row| !doc.contains(row.as_str()))
        .collect();
    assert!(
        missing.is_empty(),
        "memory-layout.md lacks these rows of the frame-size table:\n{}",
        missing.join("\n")
    );
}
