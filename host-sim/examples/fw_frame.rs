//! Write the simulated ColoRadar frame the firmware embeds (`firmware/build.rs` reads it from
//! `DBE_FW_COLORADAR_FRAME`): loop → TX → RX → sample, int16 LE, I then Q. An existing file
//! with the same content is left untouched, so cargo does not rebuild the firmware.
//!
//! ```sh
//! cargo run -p host-sim --example fw_frame -- firmware/target/frames/coloradar.frame
//! ```

use std::path::PathBuf;
use std::process::ExitCode;

use host_sim::firmware;

fn main() -> ExitCode {
    let Some(path) = std::env::args_os().nth(1).map(PathBuf::from) else {
        eprintln!("usage: fw_frame FILE");
        return ExitCode::FAILURE;
    };
    match firmware::write_coloradar_frame(&path) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fw_frame: {e}");
            ExitCode::FAILURE
        }
    }
}
