"""Time the Python chains this project is compared with (issue 13's anchors).

Run by `cargo xtask anchors`, which prepares everything; by hand:

    python anchors.py --seq SEQ --calib CALIB --dbe-radar CHECKOUT --out anchors.json

* SEQ: a ColoRadar-layout sequence (`dbe simulate` writes one), its frames
  `single_chip/adc_samples/data/frame_<i>.bin`.
* CALIB: a ColoRadar single-chip calibration folder with all four files the authors' code
  loads (`antenna_cfg.txt`, `coupling_calib.txt`, `heatmap_cfg.txt`, `waveform_cfg.txt`);
  `dbe simulate` writes only the first and the last.
* CHECKOUT: the authors' code (github.com/SenseRoboticsLab/DBE-Radar) at the commit recorded
  in the output. Its DBE chain is `SCRadar.showPointcloudFromRawBF`, called as its
  `coloradar.py ... -bfpcl` calls it, on the same int16 frame the `dbe` command reads.
* OpenRadar (PyPI `openradar`, the `mmwave` package) must be importable. Its FFT chain is the
  one of its `demo/visualizer/main.py`: range FFT, Doppler FFT, CA-CFAR along both axes, peak
  pruning and grouping, range-based pruning and the FFT angle estimate `naive_xyz`. Clutter
  removal is off, as in our FFT chain, which keeps static scatterers.

Every chain runs once per frame on one thread (BLAS threads pinned to one before numpy loads),
after one warm-up frame; the output is the median and the minimum wall time per frame.
Nothing is plotted and nothing is written but the output file.
"""

import argparse
import json
import os
import statistics
import sys
import time

for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[var] = "1"

import matplotlib  # noqa: E402

matplotlib.use("Agg")  # the authors' module imports pyplot; never open a window

import numpy as np  # noqa: E402


def read_calib(folder):
    """`key value...` lines of a ColoRadar calibration file, as the authors' parser reads them."""
    out = {}
    with open(folder) as fh:
        for line in fh:
            parts = line.split()
            if parts:
                out[parts[0]] = parts[1:]
    return out


def frames_of(seq):
    """The frame files of a ColoRadar sequence, in index order."""
    data = os.path.join(seq, "single_chip", "adc_samples", "data")
    names = [n for n in os.listdir(data) if n.startswith("frame_") and n.endswith(".bin")]
    if not names:
        sys.exit(f"no frame_<i>.bin in {data}")
    names.sort(key=lambda n: int(n[len("frame_"):-len(".bin")]))
    return [os.path.join(data, n) for n in names]


def time_chain(name, frames, run):
    """Median and minimum wall time of `run(frame)` over `frames`, after one warm-up call."""
    run(frames[0])
    times, points = [], []
    for f in frames:
        t0 = time.perf_counter()
        n = run(f)
        times.append(time.perf_counter() - t0)
        points.append(n)
    out = {
        "chain": name,
        "frames": len(frames),
        "median_ms": 1e3 * statistics.median(times),
        "min_ms": 1e3 * min(times),
        "points_per_frame": statistics.mean(points),
    }
    print(f"{name}: median {out['median_ms']:.1f} ms, min {out['min_ms']:.1f} ms per frame, "
          f"{out['points_per_frame']:.1f} points per frame", file=sys.stderr)
    return out


def authors_dbe(checkout, calib_dir):
    """The authors' DBE chain, `SCRadar.showPointcloudFromRawBF`, as a function of a frame file."""
    sys.path.insert(0, checkout)
    from core.calibration import SCRadarCalibration  # the authors' code
    from core.radar import SCRadar

    calib = SCRadarCalibration({
        k: os.path.join(calib_dir, f"{k}_cfg.txt" if k != "coupling" else "coupling_calib.txt")
        for k in ("antenna", "coupling", "heatmap", "waveform")
    })
    w = calib.waveform
    shape = (w.num_tx, w.num_rx, w.num_chirps_per_frame, w.num_adc_samples_per_chirp, 2)

    def run(path):
        # `SCRadar.__init__` without its dataset.json lookups: the same fields, the same
        # conversion of the int16 file (I + jQ through float16, as the authors do).
        radar = SCRadar.__new__(SCRadar)
        radar.sensor = "scradar"
        radar.calibration = calib
        radar.index = 0
        raw = np.fromfile(path, np.int16).reshape(shape)
        radar.raw = np.float16(raw[..., 0]) + 1j * np.float16(raw[..., 1])
        pcl = radar.showPointcloudFromRawBF()
        return 0 if pcl is None else len(pcl)

    return run


def openradar_fft(calib_dir):
    """OpenRadar's FFT chain (its visualizer demo, steps 2 to 4) as a function of a frame file."""
    import mmwave.dsp as dsp
    from mmwave.dsp.utils import Window

    wf = read_calib(os.path.join(calib_dir, "waveform_cfg.txt"))
    ntx, nrx = int(wf["num_tx"][0]), int(wf["num_rx"][0])
    loops, ns = int(wf["num_chirps_per_frame"][0]), int(wf["num_adc_samples_per_chirp"][0])
    fs_ksps = float(wf["adc_sample_frequency"][0]) / 1e3
    slope_mhz_us = float(wf["frequency_slope"][0]) / 1e12
    range_res, _ = dsp.range_resolution(ns, fs_ksps, slope_mhz_us)

    def run(path):
        raw = np.fromfile(path, np.int16).reshape(ntx, nrx, loops, ns, 2)
        cube = raw[..., 0] + 1j * raw[..., 1]
        # OpenRadar's layout: chirps in transmit order (loop-major, TX within), then RX, samples.
        frame = cube.transpose(2, 0, 1, 3).reshape(loops * ntx, nrx, ns)
        radar_cube = dsp.range_processing(frame, window_type_1d=Window.BLACKMAN)
        det_matrix, aoa_input = dsp.doppler_processing(
            radar_cube, num_tx_antennas=ntx, clutter_removal_enabled=False,
            window_type_2d=Window.HAMMING)
        fft2d_sum = det_matrix.astype(np.int64)
        thr_doppler, _ = np.apply_along_axis(
            func1d=dsp.ca_, axis=0, arr=fft2d_sum.T, l_bound=1.5, guard_len=4, noise_len=16)
        thr_range, noise_range = np.apply_along_axis(
            func1d=dsp.ca_, axis=0, arr=fft2d_sum, l_bound=2.5, guard_len=4, noise_len=16)
        mask = (det_matrix > thr_doppler.T) & (det_matrix > thr_range)
        peaks = np.argwhere(mask)
        peak_vals = fft2d_sum[peaks[:, 0], peaks[:, 1]]
        snr = peak_vals - noise_range[peaks[:, 0], peaks[:, 1]]
        det_type = np.dtype({
            "names": ["rangeIdx", "dopplerIdx", "peakVal", "location", "SNR"],
            "formats": ["<i4", "<i4", "<f4", f"({ntx},)<f4", "<f4"],
        })
        det = np.zeros((peaks.shape[0],), dtype=det_type)
        det["rangeIdx"] = peaks[:, 0]
        det["dopplerIdx"] = peaks[:, 1]
        det["peakVal"] = peak_vals
        det["SNR"] = snr
        det = dsp.prune_to_peaks(det, det_matrix, loops, reserve_neighbor=True)
        det = dsp.peak_grouping_along_doppler(det, det_matrix, loops)
        det = dsp.range_based_pruning(
            det, np.array([[2, 23], [10, 11.5], [35, 16.0]]),
            np.array([[4, 275], [1, 400], [500, 0]]), ns, 0.5, range_res)
        azimuth_input = aoa_input[det["rangeIdx"], :, det["dopplerIdx"]]
        x, _, _ = dsp.naive_xyz(azimuth_input.T, num_tx=ntx, num_rx=nrx)
        return len(x)

    return run


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seq", required=True, help="ColoRadar-layout sequence (dbe simulate)")
    ap.add_argument("--calib", required=True, help="ColoRadar single-chip calibration folder")
    ap.add_argument("--dbe-radar", required=True, help="checkout of the authors' DBE-Radar code")
    ap.add_argument("--commit", default="unknown", help="the checkout's commit, recorded")
    ap.add_argument("--out", required=True, help="JSON file to write")
    args = ap.parse_args()

    frames = frames_of(args.seq)
    calib_dir = args.calib
    import mmwave
    import scipy

    chains = [
        dict(time_chain("authors_dbe", frames, authors_dbe(args.dbe_radar, calib_dir)),
             code=f"SenseRoboticsLab/DBE-Radar {args.commit}, SCRadar.showPointcloudFromRawBF"),
        dict(time_chain("openradar_fft", frames, openradar_fft(calib_dir)),
             code="openradar (PyPI) %s, demo/visualizer/main.py steps 2-4"
             % getattr(mmwave, "__version__", "1.0.1")),
    ]
    out = {
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "chains": chains,
    }
    tmp = args.out + ".tmp"
    with open(tmp, "w") as fh:
        json.dump(out, fh, indent=2)
        fh.write("\n")
    os.replace(tmp, args.out)


if __name__ == "__main__":
    main()
