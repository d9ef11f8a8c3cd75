//! Line output over semihosting: each line is formatted into a fixed buffer and written with
//! one host call.

use core::fmt::{self, Write};

use cortex_m_semihosting::hio::{self, HostStream};

/// Longest line; longer ones are cut and end in `…` so the host parser rejects them.
const LINE: usize = 256;

/// The host's standard output.
pub struct Console {
    out: Option<HostStream>,
}

impl Console {
    /// Open the host's standard output (a failure makes every line a no-op).
    pub fn open() -> Self {
        Self {
            out: hio::hstdout().ok(),
        }
    }

    /// Write one line (a newline is appended).
    pub fn line(&mut self, args: fmt::Arguments<'_>) {
        let mut buf = Line {
            bytes: [0; LINE],
            len: 0,
            cut: false,
        };
        if buf.write_fmt(args).is_err() || buf.cut {
            buf.len = buf.len.min(LINE - 4);
            buf.push("…");
        }
        buf.push("\n");
        if let Some(out) = self.out.as_mut() {
            // A host that stops reading cannot be told anything either: ignore.
            let _ = out.write_all(&buf.bytes[..buf.len]);
        }
    }
}

/// A fixed line buffer.
struct Line {
    bytes: [u8; LINE],
    len: usize,
    cut: bool,
}

impl Line {
    fn push(&mut self, s: &str) {
        for &b in s.as_bytes() {
            if self.len < LINE {
                self.bytes[self.len] = b;
                self.len += 1;
            } else {
                self.cut = true;
            }
        }
    }
}

impl Write for Line {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.push(s);
        Ok(())
    }
}

/// `say!(console, "fmt", args…)`: one output line.
#[macro_export]
macro_rules! say {
    ($console:expr, $($arg:tt)*) => {
        $console.line(format_args!($($arg)*))
    };
}
