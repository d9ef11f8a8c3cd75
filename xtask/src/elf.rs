//! Section and named-static sizes of a firmware ELF.

use std::collections::BTreeMap;
use std::path::Path;

use crate::*;
// ---------------------------------------------------------------------------------------------
// ELF

/// One named static buffer of the firmware image.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Buffer {
    /// The `static`'s name in the firmware (`CUBE`, `WORKSPACE`, …; `other` for the rest).
    pub symbol: String,
    /// What it holds.
    pub what: String,
    /// Section (`.bss`, `.data`).
    pub section: String,
    /// Bytes.
    pub bytes: u64,
}

/// Memory of one firmware image, from its ELF.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ElfMemory {
    /// Section sizes of the allocated sections, bytes.
    pub sections: BTreeMap<String, u64>,
    /// Static RAM by buffer (every `.data`/`.bss` byte is in exactly one entry).
    pub buffers: Vec<Buffer>,
    /// Bytes of the embedded test frame (`FRAME` in `.rodata`).
    pub frame_bytes: u64,
}

impl ElfMemory {
    fn section(&self, name: &str) -> u64 {
        self.sections.get(name).copied().unwrap_or(0)
    }

    /// `.data + .bss + .uninit`.
    pub fn static_ram(&self) -> u64 {
        self.section(".data") + self.section(".bss") + self.section(".uninit")
    }

    /// What the image puts in code memory besides the test frame: vector table, `.text`,
    /// `.rodata` without the frame, and the initial values of `.data`.
    pub fn flash(&self) -> u64 {
        self.section(".vector_table") + self.section(".text") + self.section(".rodata")
            - self.frame_bytes
            + self.section(".data")
    }
}

/// The statics every image names (`firmware/src/lib.rs`, `image!`), and what they hold.
const STATICS: [(&str, &str); 7] = [
    ("CUBE", "radar cube (`CubeStorage`)"),
    (
        "WORKSPACE",
        "the chain's workspace: range bin in flight, map (DBE: range–azimuth, FFT: range–Doppler), CFAR",
    ),
    (
        "CHAIN",
        "the chain: tables and parameters (DBE: steering tables; FFT: twiddles, beamscan table)",
    ),
    (
        "FRONTEND",
        "`Frontend`: range window, coupling table, array layout",
    ),
    ("CLOUD", "`PointCloud`"),
    ("DMA_CHIRP", "one-chirp DMA buffer"),
    (
        "EGO",
        "`EgoEstimator`: gated directions and velocities of the ego-velocity stage",
    ),
];

/// The statics an image names, and what they hold (the same for both chains).
pub const fn named_statics() -> &'static [(&'static str, &'static str)] {
    &STATICS
}

/// The name a legacy-mangled Rust symbol ends with (`_ZN…4CUBE17h…E` → `CUBE`).
pub(crate) fn static_name(mangled: &str) -> Option<&str> {
    let mut rest = mangled.strip_prefix("_ZN")?;
    let mut parts = Vec::new();
    while let Some(first) = rest.chars().next() {
        if !first.is_ascii_digit() {
            break;
        }
        let digits = rest.chars().take_while(char::is_ascii_digit).count();
        let len: usize = rest[..digits].parse().ok()?;
        let ident = rest.get(digits..digits + len)?;
        parts.push(ident);
        rest = &rest[digits + len..];
    }
    // The last component is the hash `h0123…`.
    match parts.as_slice() {
        [.., name, hash] if hash.starts_with('h') => Some(name),
        [.., name] => Some(name),
        [] => None,
    }
}

/// Sections and named buffers ([`named_statics`]) of the firmware ELF at `path`.
pub fn elf_memory(path: &Path) -> Result<ElfMemory, FirmwareError> {
    let named_statics = named_statics();
    use object::{Object, ObjectSection, ObjectSymbol};
    let data = std::fs::read(path).map_err(io_err(path, "read the firmware ELF"))?;
    let bad = |message: String| FirmwareError::Elf {
        path: path.to_path_buf(),
        message,
    };
    let file = object::File::parse(&*data).map_err(|e| bad(format!("not an ELF: {e}")))?;
    let mut sections = BTreeMap::new();
    let mut index_name = BTreeMap::new();
    for s in file.sections() {
        let name = s.name().map_err(|e| bad(e.to_string()))?.to_string();
        if [
            ".vector_table",
            ".text",
            ".rodata",
            ".data",
            ".bss",
            ".uninit",
        ]
        .contains(&name.as_str())
        {
            sections.insert(name.clone(), s.size());
        }
        index_name.insert(s.index().0, name);
    }
    for needed in [".vector_table", ".text", ".bss"] {
        if !sections.contains_key(needed) {
            return Err(bad(format!("no {needed} section: not a cortex-m-rt image")));
        }
    }
    let mut named: BTreeMap<&str, Buffer> = BTreeMap::new();
    let mut frame_bytes = 0;
    for sym in file.symbols() {
        let Some(section) = sym.section_index().and_then(|i| index_name.get(&i.0)) else {
            continue;
        };
        let Some(name) = sym.name().ok().and_then(static_name) else {
            continue;
        };
        if section == ".rodata" && name == "FRAME" {
            frame_bytes = sym.size();
        }
        if section != ".data" && section != ".bss" {
            continue;
        }
        if let Some((symbol, what)) = named_statics.iter().find(|(s, _)| *s == name) {
            named.insert(
                symbol,
                Buffer {
                    symbol: (*symbol).into(),
                    what: (*what).into(),
                    section: section.clone(),
                    bytes: sym.size(),
                },
            );
        }
    }
    if frame_bytes == 0 {
        return Err(bad(
            "no FRAME symbol in .rodata (the embedded test frame)".into()
        ));
    }
    let mut buffers: Vec<Buffer> = named_statics
        .iter()
        .filter_map(|(s, _)| named.remove(s))
        .collect();
    if buffers.len() != named_statics.len() {
        let found: Vec<&str> = buffers.iter().map(|b| b.symbol.as_str()).collect();
        let expected: Vec<&str> = named_statics.iter().map(|(s, _)| *s).collect();
        return Err(bad(format!(
            "expected the statics {expected:?}, found {found:?}"
        )));
    }
    let memory = ElfMemory {
        sections,
        buffers: Vec::new(),
        frame_bytes,
    };
    let named_total: u64 = buffers.iter().map(|b| b.bytes).sum();
    buffers.push(Buffer {
        symbol: "other".into(),
        what: "everything else (runtime, semihosting, alignment)".into(),
        section: ".data/.bss".into(),
        bytes: memory.static_ram().saturating_sub(named_total),
    });
    Ok(ElfMemory { buffers, ..memory })
}
