//! Bad input: typed errors for bad configuration and bad chirp order, no panic on any data.

mod common;

use common::{dbe_for, id, storage};
use dbe_radar::config::Param;
use dbe_radar::presets::coloradar as p;
use dbe_radar::{
    AntennaGeometry, CfarParams, Chain, ChirpId, ConfigError, FrameError, Params, Waveform,
};

fn frontend() -> p::Frontend {
    p::frontend().expect("defaults are valid")
}

fn dbe() -> p::Dbe {
    p::dbe(&frontend()).expect("defaults are valid")
}

fn feed(frontend: &p::Frontend, cube: &mut p::Cube<'_>, chirp: impl Fn(usize) -> p::Chirp) {
    for i in 0..p::LOOPS * p::TX {
        frontend
            .push_chirp(cube, id(i, p::TX), &chirp(i))
            .expect("in order");
    }
}

#[test]
fn config_errors_name_the_parameter() {
    let w = Waveform::COLORADAR;
    let g = AntennaGeometry::COLORADAR;
    let d = Params::defaults(p::SAMPLES);
    let err = |w, g, params| dbe_for(w, g, params).err();
    assert_eq!(
        err(
            Waveform {
                slope_hz_per_s: f64::NAN,
                ..w
            },
            g,
            d
        ),
        Some(ConfigError::NotFinite(Param::Slope))
    );
    assert_eq!(
        err(
            Waveform {
                adc_sample_rate_hz: 0.0,
                ..w
            },
            g,
            d
        ),
        Some(ConfigError::OutOfRange(Param::AdcSampleRate))
    );
    assert_eq!(
        err(
            w,
            g,
            Params {
                range_last: p::SAMPLES as u16,
                ..d
            }
        ),
        Some(ConfigError::OutOfRange(Param::RangeWindow))
    );
    assert_eq!(
        err(w, g, Params { loading: -1.0, ..d }),
        Some(ConfigError::OutOfRange(Param::Loading))
    );
    let wide = CfarParams {
        train_cross: 60,
        train_range: 20,
        ..CfarParams::RANGE_AZIMUTH
    };
    assert_eq!(
        err(w, g, Params { cfar: wide, ..d }),
        Some(ConfigError::OutOfRange(Param::CfarWindow))
    );
    // TX1 moved from az 4 to az 5: the azimuth line has a gap.
    let mut gap = g;
    gap.tx[1].0 = 5.0;
    assert_eq!(err(w, gap, d), Some(ConfigError::AzimuthNotUniform));
    // Every TX at elevation 0: 12 elements on the azimuth line, not 8.
    let mut flat = g;
    flat.tx[2] = (8.0, 0.0);
    assert_eq!(
        err(w, flat, d),
        Some(ConfigError::AzimuthRowCount {
            found: 12,
            expected: 8
        })
    );
    let msg = ConfigError::NotFinite(Param::Slope).to_string();
    assert!(msg.contains("frequency_slope"), "{msg}");
}

#[test]
fn finite_but_absurd_configurations_are_refused() {
    // Found by fuzzing: each passed validation and gave inf/NaN points or silently none.
    let w = Waveform::COLORADAR;
    let g = AntennaGeometry::COLORADAR;
    let d = Params::defaults(p::SAMPLES);
    let refused = |w: Waveform, g: AntennaGeometry<3, 4>| dbe_for(w, g, d).err();
    let cases = [
        (
            Waveform {
                slope_hz_per_s: 1e-30,
                ..w
            },
            Param::Slope,
        ),
        (
            Waveform {
                adc_sample_rate_hz: 1e300,
                ..w
            },
            Param::AdcSampleRate,
        ),
        (
            Waveform {
                start_frequency_hz: 1e300,
                ..w
            },
            Param::StartFrequency,
        ),
        (
            Waveform {
                start_frequency_hz: 77.0,
                ..w
            },
            Param::StartFrequency,
        ),
        (
            Waveform {
                idle_time_s: 0.0,
                ramp_end_time_s: 1e-300,
                ..w
            },
            Param::RampEndTime,
        ),
        (
            Waveform {
                idle_time_s: -1e-6,
                ..w
            },
            Param::IdleTime,
        ),
    ];
    for (bad, param) in cases {
        assert_eq!(
            refused(bad, g),
            Some(ConfigError::OutOfRange(param)),
            "{bad:?}"
        );
    }
    let tiny = AntennaGeometry {
        f_design_hz: 1e-300,
        ..g
    };
    assert_eq!(
        refused(w, tiny),
        Some(ConfigError::OutOfRange(Param::DesignFrequency))
    );
}

#[test]
fn every_accepted_waveform_has_finite_bins() {
    // The corners of the limits: whatever validation accepts gives finite, positive bin sizes
    // and wavelengths, so no point can be non-finite because of the configuration.
    use dbe_radar::config::limits as l;
    let g = AntennaGeometry::COLORADAR;
    let d = Params::defaults(p::SAMPLES);
    for fs in [l::ADC_SAMPLE_RATE_HZ.0, l::ADC_SAMPLE_RATE_HZ.1] {
        for slope in [l::SLOPE_HZ_PER_S.0, l::SLOPE_HZ_PER_S.1] {
            for f0 in [l::START_FREQUENCY_HZ.0, l::START_FREQUENCY_HZ.1] {
                for ramp in [l::RAMP_END_TIME_S.0, l::RAMP_END_TIME_S.1] {
                    let w = Waveform {
                        adc_sample_rate_hz: fs,
                        slope_hz_per_s: slope,
                        start_frequency_hz: f0,
                        idle_time_s: 0.0,
                        ramp_end_time_s: ramp,
                    };
                    assert!(dbe_for(w, g, d).is_ok(), "{w:?} refused");
                    for v in [
                        w.range_bin_m(p::SAMPLES),
                        w.doppler_bin_mps(p::SAMPLES, p::LOOPS, p::TX),
                        w.wavelength_m(p::SAMPLES),
                    ] {
                        assert!(v.is_finite() && v > 0.0, "{w:?}: {v}");
                    }
                }
            }
        }
    }
}

#[test]
fn the_fixture_geometry_puts_tx1_on_the_elevation_row() {
    let (d, _) = dbe_for(
        Waveform::IWR6843_FIXTURE,
        AntennaGeometry::IWR6843_FIXTURE,
        Params::defaults(p::SAMPLES),
    )
    .expect("valid");
    let l = d.layout();
    // Azimuth line: TX0 (az 0..3) then TX2 (az 4..7); elevation row: TX1 (az 2..5, el 1).
    assert_eq!(l.row_of, [[0, 1, 2, 3], [8, 9, 10, 11], [4, 5, 6, 7]]);
    assert_eq!(l.az, [0., 1., 2., 3., 4., 5., 6., 7., 2., 3., 4., 5.]);
    assert_eq!(l.el, [0., 0., 0., 0., 0., 0., 0., 0., 1., 1., 1., 1.]);
    assert_eq!(l.slot, [0, 0, 0, 0, 2, 2, 2, 2, 1, 1, 1, 1]);
}

#[test]
fn missing_repeated_and_extra_chirps_are_frame_errors() {
    let f = frontend();
    let zero: p::Chirp = [[[0, 0]; p::SAMPLES]; p::RX];
    let mut st = storage();
    let mut cube = p::Cube::new(&mut st);

    // A missing chirp (slot 1 of loop 0 skipped).
    f.push_chirp(&mut cube, id(0, 3), &zero).unwrap();
    let got = ChirpId {
        loop_index: 0,
        tx_slot: 2,
    };
    let expected = ChirpId {
        loop_index: 0,
        tx_slot: 1,
    };
    assert_eq!(
        f.push_chirp(&mut cube, got, &zero),
        Err(FrameError::OutOfOrder { expected, got })
    );
    // The frame stays poisoned even if the right chirps follow.
    f.push_chirp(&mut cube, expected, &zero).unwrap_err();
    assert_eq!(
        f.frame(&cube).err(),
        Some(FrameError::OutOfOrder { expected, got })
    );

    // A repeated chirp.
    cube.begin_frame();
    f.push_chirp(&mut cube, id(0, 3), &zero).unwrap();
    assert!(matches!(
        f.push_chirp(&mut cube, id(0, 3), &zero),
        Err(FrameError::OutOfOrder { .. })
    ));

    // An incomplete frame.
    cube.begin_frame();
    f.push_chirp(&mut cube, id(0, 3), &zero).unwrap();
    assert_eq!(
        f.frame(&cube).err(),
        Some(FrameError::Incomplete {
            received: 1,
            expected: 384
        })
    );

    // One chirp too many.
    cube.begin_frame();
    feed(&f, &mut cube, |_| zero);
    assert!(f.frame(&cube).is_ok());
    assert_eq!(
        f.push_chirp(&mut cube, id(0, 3), &zero),
        Err(FrameError::TooManyChirps)
    );
    assert_eq!(f.frame(&cube).err(), Some(FrameError::TooManyChirps));
}

#[test]
fn degenerate_frames_do_not_panic() {
    let f = frontend();
    let d = dbe();
    let mut st = storage();
    let mut cube = p::Cube::new(&mut st);
    let mut work = Box::new(p::Workspace::new());
    let mut cloud = Box::new(p::PointCloud::new());
    let kept = u32::from(d.params().range_last - d.params().range_first + 1);

    // All zero: no covariance is positive definite, every bin is skipped and counted.
    feed(&f, &mut cube, |_| [[[0, 0]; p::SAMPLES]; p::RX]);
    d.process(&f.frame(&cube).unwrap(), &mut work, &mut cloud);
    assert_eq!(cloud.stats.skipped_range_bins, kept);
    assert_eq!(cloud.points().len(), 0);

    // Saturated ADC (a constant is pure DC, removed before the FFT): same as zero.
    cube.begin_frame();
    feed(&f, &mut cube, |_| {
        [[[i16::MAX, i16::MIN]; p::SAMPLES]; p::RX]
    });
    d.process(&f.frame(&cube).unwrap(), &mut work, &mut cloud);
    assert_eq!(cloud.stats.skipped_range_bins, kept);

    // Full-scale square wave on every channel, alternating sign per chirp.
    cube.begin_frame();
    feed(&f, &mut cube, |i| {
        core::array::from_fn(|_| {
            core::array::from_fn(|n| {
                let s = if (n / 4 + i) % 2 == 0 {
                    i16::MAX
                } else {
                    i16::MIN
                };
                [s, s]
            })
        })
    });
    d.process(&f.frame(&cube).unwrap(), &mut work, &mut cloud);
    assert!(cloud.stats.points as usize == cloud.points().len());

    // One hot antenna (TX0/RX2 only): rank-deficient covariance, loading keeps it usable.
    cube.begin_frame();
    feed(&f, &mut cube, |i| {
        core::array::from_fn(|r| {
            core::array::from_fn(|n| {
                if i % p::TX == 0 && r == 2 {
                    [(n as i16 * 97) % 3000, (n as i16 * 31) % 2000]
                } else {
                    [0, 0]
                }
            })
        })
    });
    d.process(&f.frame(&cube).unwrap(), &mut work, &mut cloud);
    for pt in cloud.points() {
        assert!(pt.position.is_finite() && pt.power_db.is_finite() && pt.snr_db.is_finite());
    }
}

#[test]
fn detection_and_point_capacities_overflow_gracefully() {
    use dbe_radar::{Dbe, PointCloud, Workspace};
    let f = frontend();
    // Room for 2 detections and 1 point.
    let d = Dbe::<
        { p::SAMPLES },
        { p::LOOPS },
        { p::TX },
        { p::RX },
        { p::VIRTUAL },
        { p::AZIMUTH },
        { p::AZIMUTH_BINS },
        { p::ELEVATION_BINS },
        2,
    >::new(&f, p::params())
    .unwrap();
    // Many targets.
    let targets: Vec<common::Target> = (0..6)
        .map(|i| {
            common::Target::polar(
                3.0 + 1.5 * i as f64,
                -40.0 + 15.0 * i as f64,
                0.0,
                0.0,
                50.0,
            )
        })
        .collect();
    let chirps = common::synth::<{ p::SAMPLES }, { p::LOOPS }, { p::TX }, { p::RX }>(
        &Waveform::COLORADAR,
        &AntennaGeometry::COLORADAR,
        &targets,
        10.0,
        7,
    );
    let mut st = storage();
    let mut cube = p::Cube::new(&mut st);
    feed(&f, &mut cube, |i| chirps[i]);
    let mut work = Box::new(Workspace::<
        { p::SAMPLES },
        { p::LOOPS },
        { p::VIRTUAL },
        { p::AZIMUTH_BINS },
        2,
    >::new());
    let mut cloud = Box::new(PointCloud::<1>::new());
    d.process(&f.frame(&cube).unwrap(), &mut work, &mut cloud);
    assert_eq!(cloud.stats.detections, 2);
    assert!(cloud.stats.detection_overflow >= 4, "{:?}", cloud.stats);
    assert_eq!(cloud.points().len(), 1);
    assert!(cloud.stats.point_overflow >= 1);
}

#[test]
fn in_place_configuration_matches_new_and_rejects_without_change() {
    let mut f = Box::new(p::Frontend::unconfigured());
    let mut d = Box::new(p::Dbe::unconfigured());
    // Unconfigured: no panic, no points.
    let mut st = storage();
    let mut cube = p::Cube::new(&mut st);
    let chirp: p::Chirp = core::array::from_fn(|_| core::array::from_fn(|n| [n as i16, 7]));
    feed(&f, &mut cube, |_| chirp);
    let mut work = Box::new(p::Workspace::new());
    let mut cloud = Box::new(p::PointCloud::new());
    d.process(&f.frame(&cube).unwrap(), &mut work, &mut cloud);
    assert_eq!(cloud.points().len(), 0);
    // A chain cannot be configured from an unconfigured frontend.
    let defaults = Params::defaults(p::SAMPLES);
    assert_eq!(
        d.configure(&f, defaults),
        Err(ConfigError::FrontendUnconfigured)
    );

    f.configure(
        Waveform::COLORADAR,
        AntennaGeometry::COLORADAR,
        defaults.range_window,
    )
    .unwrap();
    d.configure(&f, defaults).unwrap();
    let reference = dbe();
    assert_eq!(d.azimuth_grid(), reference.azimuth_grid());
    assert_eq!(f.layout(), frontend().layout());
    assert_eq!(d.range_bin_m(), reference.range_bin_m());
    // A rejected configuration leaves the frontend and the chain as they were.
    assert_eq!(
        f.configure(
            Waveform {
                slope_hz_per_s: -1.0,
                ..Waveform::IWR6843_FIXTURE
            },
            AntennaGeometry::COLORADAR,
            defaults.range_window
        ),
        Err(ConfigError::OutOfRange(Param::Slope))
    );
    assert_eq!(f.waveform(), frontend().waveform());
    let bad = Params {
        loading: f32::NAN,
        ..defaults
    };
    assert_eq!(
        d.configure(&f, bad),
        Err(ConfigError::NotFinite(Param::Loading))
    );
    assert_eq!(d.params(), reference.params());
    // A chain whose range window is not the frontend's is refused.
    let hann = Params {
        range_window: dbe_radar::window::WindowKind::Hann,
        ..defaults
    };
    assert_eq!(
        d.configure(&f, hann),
        Err(ConfigError::OutOfRange(Param::RangeWindowKind))
    );
}
