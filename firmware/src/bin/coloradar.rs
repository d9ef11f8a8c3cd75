//! The DBE chain, ColoRadar preset (128 samples × 128 loops), on one simulated frame.
#![no_std]
#![no_main]

dbe_firmware::image!(coloradar, Dbe, params, "coloradar.frame");
