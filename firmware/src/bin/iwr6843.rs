//! The DBE chain, IWR6843 preset (256 samples × 64 loops), on the TI corner-reflector capture.
#![no_std]
#![no_main]

dbe_firmware::image!(iwr6843, Dbe, params, "iwr6843.frame");
