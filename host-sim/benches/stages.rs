//! One benchmark per stage and per chain on a simulated ColoRadar corridor frame, one thread:
//!
//! ```sh
//! cargo bench -p host-sim --bench stages            # criterion statistics per stage
//! cargo run --release -p host-sim --bin dbe -- bench  # the same stages as one table
//! ```
//!
//! `ingest` is `Frontend::push_chirp` for the frame's 384 chirps and the frame check; each
//! chain stage runs on a workspace the previous stages filled (the stages are idempotent), so
//! the sum of a chain's stages is its `process`. The previous stages are run before each
//! benchmark, not left to the benchmarks before it: a filter
//! (`cargo bench -p host-sim --bench stages -- dbe/elevation_doppler`) skips those.

// `criterion_group!` defines an undocumented `pub fn benches`.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, Criterion};
use dbe_radar::presets::coloradar as p;
use dbe_radar::Chain;
use host_sim::frame::AdcFrame;
use host_sim::sensor::SensorConfig;
use host_sim::sim::{Scene, Simulation};

/// The corridor scene's first frame.
fn corridor_frame() -> AdcFrame {
    let text = include_str!("../scenes/corridor.toml");
    let scene = Scene::from_toml_str(text, "corridor").expect("the shipped scene parses");
    let sim = Simulation::new(&scene, &SensorConfig::coloradar()).expect("ColoRadar sensor");
    sim.frame(0).expect("frame 0 renders").adc
}

/// The frame's chirps in TDM order, as a DMA would deliver them.
fn chirps(frame: &AdcFrame) -> Vec<p::Chirp> {
    let mut out = Vec::with_capacity(p::LOOPS * p::TX);
    for k in 0..p::LOOPS {
        for t in 0..p::TX {
            let mut c: p::Chirp = [[[0; 2]; p::SAMPLES]; p::RX];
            for (dst, src) in c.iter_mut().zip(frame.chirp(k, t).chunks_exact(p::SAMPLES)) {
                dst.copy_from_slice(src);
            }
            out.push(c);
        }
    }
    out
}

fn ingest(frontend: &p::Frontend, cube: &mut p::Cube<'_>, chirps: &[p::Chirp]) {
    cube.begin_frame();
    for (id, c) in frontend.tdm_order().zip(chirps.iter()) {
        frontend
            .push_chirp(cube, id, c)
            .expect("chirps in TDM order");
    }
}

fn stages(c: &mut Criterion) {
    let chirps = chirps(&corridor_frame());
    let frontend = p::frontend().expect("defaults");
    let dbe = Box::new(p::dbe(&frontend).expect("defaults"));
    let fft = Box::new(p::fft_chain(&frontend).expect("defaults"));
    let mut storage: Box<p::CubeStorage> = vec![[[[0; 2]; p::VIRTUAL]; p::LOOPS]; p::SAMPLES]
        .into_boxed_slice()
        .try_into()
        .expect("SAMPLES range bins");
    let mut cube = p::Cube::new(&mut storage);
    let mut cloud = Box::new(p::PointCloud::new());

    c.bench_function("ingest", |b| {
        b.iter(|| ingest(&frontend, &mut cube, &chirps))
    });
    ingest(&frontend, &mut cube, &chirps);
    let frame = frontend.frame(&cube).expect("a complete frame");

    let mut work = Box::new(p::Workspace::new());
    c.bench_function("dbe/azimuth_capon", |b| {
        b.iter(|| dbe.map(&frame, &mut work))
    });
    dbe.map(&frame, &mut work);
    c.bench_function("dbe/cfar", |b| b.iter(|| dbe.detect(&mut work)));
    dbe.detect(&mut work);
    assert!(
        !p::Dbe::detections(&work).is_empty(),
        "the frame has DBE detections"
    );
    c.bench_function("dbe/elevation_doppler", |b| {
        b.iter(|| dbe.points(&frame, &mut work, &mut cloud))
    });
    c.bench_function("dbe/process", |b| {
        b.iter(|| dbe.process(&frame, &mut work, &mut cloud))
    });

    let mut fwork = Box::new(p::FftWorkspace::new());
    c.bench_function("fft/doppler_fft", |b| {
        b.iter(|| fft.map(&frame, &mut fwork))
    });
    fft.map(&frame, &mut fwork);
    c.bench_function("fft/rd_cfar", |b| b.iter(|| fft.detect(&mut fwork)));
    fft.detect(&mut fwork);
    assert!(
        !p::FftChain::detections(&fwork).is_empty(),
        "the frame has FFT detections"
    );
    c.bench_function("fft/angles", |b| {
        b.iter(|| fft.points(&frame, &mut fwork, &mut cloud))
    });
    c.bench_function("fft/process", |b| {
        b.iter(|| fft.process(&frame, &mut fwork, &mut cloud))
    });
}

criterion_group!(benches, stages);
criterion_main!(benches);
