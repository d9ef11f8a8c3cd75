//! The FFT baseline chain, ColoRadar preset (128 samples × 128 loops), on the `coloradar`
//! image's simulated frame.
#![no_std]
#![no_main]

dbe_firmware::image!(coloradar, FftChain, fft_params, "coloradar.frame");
