//! GSD trajectories: HOOMD-blue's General Simulation Data format (file layer 2.1, `hoomd`
//! schema 1.4 or 2.0), which freud, OVITO, MDAnalysis, signac and HOOMD-blue itself read.
//!
//! A [`GsdWriter`] appends [`GsdFrame`]s to one file; [`GsdFile`] reads them back.
//!
//! **What a frame holds** (the `hoomd` schema's chunk names): `configuration/step`,
//! `configuration/dimensions` (2 or 3), `configuration/box` (`Lx, Ly, Lz, xy, xz, yz`, with
//! `Lz = 0` in 2D), `particles/N`, `particles/position` and optionally
//! `particles/velocity`, `particles/types` with `particles/typeid`, `particles/diameter`,
//! `particles/mass`, and any per-particle or global quantity under `log/...` (for example
//! `log/particles/angular_velocity`, which `gsd.hoomd` returns in `frame.log`; OVITO makes
//! it a particle property).
//!
//! **Precision**: a trajectory's positions, velocities, box, diameters and masses are f32
//! (schema 1.4, the format's classic form that every reader opens) or f64 (schema 2.0:
//! exact frames of an f64 run, for gsd 4 or later and OVITO 3.17; older readers refuse
//! them), chosen in [`GsdWriter::create`]. `log/` arrays are f64 in both. A [`GsdFrame`]
//! holds f64 values; [`GsdFrame::rounded`] gives what an f32 file returns.
//!
//! **Positions are stored relative to the box centre**, because a HOOMD box is centred on the
//! origin: a simulation box `[lo, hi]` becomes `L = hi - lo` and every coordinate is written
//! as `x - (lo + hi) / 2`. Particles outside the box are written as they are; readers that
//! wrap or bin (freud) expect periodic coordinates wrapped into the box.
//!
//! **Chunks equal to frame 0's are not repeated** (types, masses and diameters of a run that
//! keeps them; the box of a fixed container): the schema defines a missing chunk as frame
//! 0's, and every reader of the format fills it in, as [`GsdFile::frame`] does.
//!
//! **A crash leaves every completed frame readable.** A frame's data is appended to the
//! end of the file first, then its index entries are written in one write into the free
//! slots of the index, which is what makes the frame exist for a reader; when the index or
//! the name list is full, a larger copy is written at the end of the file and the 256-byte
//! header is rewritten to point at it only once the copy is complete. A killed process
//! therefore leaves the frames it finished and at most some unreferenced bytes at the end.
//! [`GsdWriter::sync_each_frame`] (on by default) also syncs the data to the disk before
//! the index that refers to it, so that a power failure keeps the same promise; turn it off
//! for frames written faster than the disk syncs.
//!
//! **Restarts**: [`GsdWriter::resume`] reopens a trajectory after a run restarted from a
//! checkpoint, dropping the frames written after the checkpoint's step, so the trajectory
//! continues without repeated frames.
//!
//! Byte order: little-endian, as every GSD file written on the platforms that write them.
//!
//! ```
//! use simkit_backend::Precision;
//! use simkit_output::gsd::{GsdFile, GsdFrame, GsdWriter};
//! # fn main() -> simkit_backend::Result<()> {
//! let path = std::env::temp_dir().join("simkit-doc-gsd").join("traj.gsd");
//! let mut traj = GsdWriter::create(&path, Precision::F32)?;
//! for step in 0..3u64 {
//!     let x = step as f64 * 0.5;
//!     // Two discs in the box [0, 4] x [0, 4]; stored relative to its centre (2, 2).
//!     let mut frame = GsdFrame::new(step * 100, &[x, 1.0, 3.0, 2.0], 2, &[0.0, 0.0], &[4.0, 4.0])?;
//!     frame
//!         .velocities(&[1.0, 0.0, -1.0, 0.0], 2)?
//!         .types(&[0u32, 1], &["small", "large"])?
//!         .diameters(&[0.5, 1.0])?;
//!     traj.push(&frame)?;
//! }
//! let file = GsdFile::open(&path)?;
//! assert_eq!(file.frames(), 3);
//! let last = file.frame(2)?;
//! assert_eq!(last.step(), 200);
//! // Values as an f32 file holds them (these are exact in f32).
//! assert_eq!(&last.positions()[..3], &[-1.0, -1.0, 0.0]);
//! assert_eq!(last.type_names(), ["small", "large"]);
//! # Ok(())
//! # }
//! ```

mod frame;
mod read;
mod write;

pub use frame::GsdFrame;
pub use read::GsdFile;
pub use write::GsdWriter;

/// The file's magic number.
const MAGIC: u64 = 0x65DF_65DF_65DF_65DF;
/// File layer version 2.1 (`major << 16 | minor`).
const GSD_VERSION: u32 = 2 << 16 | 1;
/// `hoomd` schema version 1.4: floats are f32 (what every reader of the format opens).
const SCHEMA_F32: u32 = 1 << 16 | 4;
/// `hoomd` schema version 2.0: floats may be f64 (gsd 4 and later, OVITO 3.17).
const SCHEMA_F64: u32 = 2 << 16;
/// Header size in bytes.
const HEADER: usize = 256;
/// Index entry size in bytes.
const ENTRY: usize = 32;
/// The name list is allocated in segments of this many bytes.
const NAME_SEGMENT: u64 = 64;
/// Index entries of a new file.
const INITIAL_ENTRIES: u64 = 128;
/// Name-list segments of a new file (1 KiB).
const INITIAL_SEGMENTS: u64 = 16;
/// The application name written into the header.
const APPLICATION: &str = concat!("simkit ", env!("CARGO_PKG_VERSION"));

/// The data type of a chunk (the file layer's type codes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChunkType {
    /// `uint8`.
    U8 = 1,
    /// `uint16`.
    U16 = 2,
    /// `uint32`.
    U32 = 3,
    /// `uint64`.
    U64 = 4,
    /// `int8`.
    I8 = 5,
    /// `int16`.
    I16 = 6,
    /// `int32`.
    I32 = 7,
    /// `int64`.
    I64 = 8,
    /// `float` (f32).
    F32 = 9,
    /// `double` (f64).
    F64 = 10,
    /// UTF-8 characters.
    Char = 11,
}

impl ChunkType {
    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            Self::U8 | Self::I8 | Self::Char => 1,
            Self::U16 | Self::I16 => 2,
            Self::U32 | Self::I32 | Self::F32 => 4,
            Self::U64 | Self::I64 | Self::F64 => 8,
        }
    }

    fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            1 => Self::U8,
            2 => Self::U16,
            3 => Self::U32,
            4 => Self::U64,
            5 => Self::I8,
            6 => Self::I16,
            7 => Self::I32,
            8 => Self::I64,
            9 => Self::F32,
            10 => Self::F64,
            11 => Self::Char,
            _ => return None,
        })
    }
}

/// One named array of a frame: `rows x columns` elements of one type, little-endian.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chunk {
    kind: ChunkType,
    rows: u64,
    columns: u32,
    bytes: Vec<u8>,
}

impl Chunk {
    fn from_f32(columns: u32, values: &[f32]) -> Self {
        Self::new(
            ChunkType::F32,
            columns,
            values.iter().flat_map(|v| v.to_le_bytes()),
        )
    }
    fn from_f64(columns: u32, values: &[f64]) -> Self {
        Self::new(
            ChunkType::F64,
            columns,
            values.iter().flat_map(|v| v.to_le_bytes()),
        )
    }
    fn from_u32(values: &[u32]) -> Self {
        Self::new(
            ChunkType::U32,
            1,
            values.iter().flat_map(|v| v.to_le_bytes()),
        )
    }
    fn new(kind: ChunkType, columns: u32, bytes: impl Iterator<Item = u8>) -> Self {
        let bytes: Vec<u8> = bytes.collect();
        let rows = (bytes.len() / (kind.size() * columns as usize)) as u64;
        Self {
            kind,
            rows,
            columns,
            bytes,
        }
    }
    /// The element type.
    pub fn kind(&self) -> ChunkType {
        self.kind
    }
    /// Rows (`N`).
    pub fn rows(&self) -> u64 {
        self.rows
    }
    /// Columns (`M`).
    pub fn columns(&self) -> u32 {
        self.columns
    }
    /// The raw little-endian bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }
    /// The values as f64: floats exactly, integers exactly up to 2^53; `None` for
    /// characters.
    pub fn to_f64(&self) -> Option<Vec<f64>> {
        let size = self.kind.size();
        let words = self.bytes.chunks_exact(size);
        let le = |b: &[u8]| {
            let mut w = [0u8; 8];
            w[..b.len()].copy_from_slice(b);
            u64::from_le_bytes(w)
        };
        let signed = |b: &[u8]| {
            let shift = 64 - 8 * b.len() as u32;
            ((le(b) << shift) as i64 >> shift) as f64
        };
        Some(match self.kind {
            ChunkType::F32 => words
                .map(|b| f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])))
                .collect(),
            ChunkType::F64 => words.map(|b| f64::from_bits(le(b))).collect(),
            ChunkType::U8 | ChunkType::U16 | ChunkType::U32 | ChunkType::U64 => {
                words.map(|b| le(b) as f64).collect()
            }
            ChunkType::I8 | ChunkType::I16 | ChunkType::I32 | ChunkType::I64 => {
                words.map(signed).collect()
            }
            ChunkType::Char => return None,
        })
    }
    /// The values of a `U32` chunk; `None` for another type.
    pub fn to_u32(&self) -> Option<Vec<u32>> {
        (self.kind == ChunkType::U32).then(|| {
            let w = self.bytes.chunks_exact(4);
            w.map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect()
        })
    }
    /// The value of a 1 x 1 `U64` chunk.
    fn to_u64_scalar(&self) -> Option<u64> {
        (self.kind == ChunkType::U64 && self.bytes.len() == 8)
            .then(|| u64::from_le_bytes(self.bytes[..8].try_into().expect("8 bytes")))
    }
}

/// The `hoomd` schema's rule for a chunk `name` that a frame lacks: it is frame 0's, except
/// a particle chunk between frames of different particle counts (`same_count` false), which
/// takes its default.
fn inherits_from_frame_0(name: &str, same_count: bool) -> bool {
    same_count || !name.starts_with("particles/")
}

/// One index entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Entry {
    frame: u64,
    rows: u64,
    location: u64,
    columns: u32,
    id: u16,
    kind: ChunkType,
}

impl Entry {
    fn to_bytes(self) -> [u8; ENTRY] {
        let mut b = [0u8; ENTRY];
        b[0..8].copy_from_slice(&self.frame.to_le_bytes());
        b[8..16].copy_from_slice(&self.rows.to_le_bytes());
        b[16..24].copy_from_slice(&self.location.to_le_bytes());
        b[24..28].copy_from_slice(&self.columns.to_le_bytes());
        b[28..30].copy_from_slice(&self.id.to_le_bytes());
        b[30] = self.kind as u8;
        b
    }
    fn size(self) -> u64 {
        self.rows * u64::from(self.columns) * self.kind.size() as u64
    }
}

/// The header fields that change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Header {
    schema_version: u32,
    index_location: u64,
    index_entries: u64,
    names_location: u64,
    name_segments: u64,
}

impl Header {
    fn to_bytes(self) -> [u8; HEADER] {
        let mut b = [0u8; HEADER];
        b[0..8].copy_from_slice(&MAGIC.to_le_bytes());
        b[8..16].copy_from_slice(&self.index_location.to_le_bytes());
        b[16..24].copy_from_slice(&self.index_entries.to_le_bytes());
        b[24..32].copy_from_slice(&self.names_location.to_le_bytes());
        b[32..40].copy_from_slice(&self.name_segments.to_le_bytes());
        b[40..44].copy_from_slice(&self.schema_version.to_le_bytes());
        b[44..48].copy_from_slice(&GSD_VERSION.to_le_bytes());
        b[48..48 + APPLICATION.len()].copy_from_slice(APPLICATION.as_bytes());
        b[112..117].copy_from_slice(b"hoomd");
        b
    }
}

/// The little-endian `u64` at byte `at` of `b`.
fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"))
}
