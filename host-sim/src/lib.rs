//! Host-side tooling for dbe-radar: the reference implementation, the FMCW simulator, readers
//! and writers of recorded data, the validation harness and the `dbe` command.

pub mod cloud;
pub mod frame;
pub mod sensor;
