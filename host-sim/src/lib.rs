//! Host-side tooling for dbe-radar: the reference implementation, the FMCW simulator, readers
//! and writers of recorded data, the validation harness and the `dbe` command.

pub mod calibrate;
pub mod cloud;
pub mod core_run;
pub mod eval;
pub mod frame;
pub mod harness;
pub mod io;
pub mod odometry;
pub mod plot;
pub mod reference;
pub mod score;
pub mod sensor;
pub mod sim;
