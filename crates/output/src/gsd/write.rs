//! [`GsdWriter`]: frames appended in the order that keeps every completed one readable.

use std::fs::{File, OpenOptions};
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::{
    Chunk, ChunkType, ENTRY, Entry, GsdFile, GsdFrame, HEADER, Header, INITIAL_ENTRIES,
    INITIAL_SEGMENTS, NAME_SEGMENT, SCHEMA_F32, SCHEMA_F64, inherits_from_frame_0,
};
use crate::atomic::{io_error, write_atomic};
use simkit_backend::{Error, Precision, Result};

/// Whether a chunk is left out of a frame when it equals frame 0's (all but the step and
/// the `log/` quantities).
fn name_is_attribute(name: &str) -> bool {
    name != "configuration/step" && !name.starts_with("log/")
}

/// Appends frames to a GSD file; see the [module docs](super).
#[derive(Debug)]
pub struct GsdWriter {
    file: File,
    path: PathBuf,
    header: Header,
    precision: Precision,
    names: Vec<String>,
    /// Bytes of the name list in use (names and their NUL bytes).
    names_used: u64,
    entries: Vec<Entry>,
    frames: u64,
    /// Frame 0's chunks by name id (a later chunk equal to one of these is not written).
    initial: Vec<(u16, Chunk)>,
    sync: bool,
    /// Writes allowed before an injected failure (tests of the write order); `None`: all.
    writes_left: Option<u64>,
    /// Set once a write failed: the file holds every frame before it, the writer no more.
    failed: Option<String>,
}

impl GsdWriter {
    /// Creates (or replaces) the trajectory `path`, empty, with floats (positions,
    /// velocities, box, diameters, masses) at `precision`: `F32` writes `hoomd` schema 1.4,
    /// which every reader of the format opens (HOOMD-blue's own default); `F64` writes
    /// schema 2.0, exact double-precision frames, which gsd 4 or later and OVITO 3.17 read
    /// (older readers refuse the file). Header, index and name list are written
    /// atomically, so a crash leaves no half-made file. Parent directories are created.
    ///
    /// Errors: the file cannot be written.
    pub fn create(path: impl AsRef<Path>, precision: Precision) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let schema_version = match precision {
            Precision::F32 => SCHEMA_F32,
            Precision::F64 => SCHEMA_F64,
        };
        let header = Header {
            schema_version,
            index_location: HEADER as u64,
            index_entries: INITIAL_ENTRIES,
            names_location: HEADER as u64 + INITIAL_ENTRIES * ENTRY as u64,
            name_segments: INITIAL_SEGMENTS,
        };
        let blocks = (INITIAL_ENTRIES * ENTRY as u64 + INITIAL_SEGMENTS * NAME_SEGMENT) as usize;
        write_atomic(&path, |w| {
            w.write_all(&header.to_bytes())?;
            w.write_all(&vec![0u8; blocks])
        })?;
        Self::reopen(path, header, precision, Vec::new(), Vec::new(), Vec::new())
    }

    /// Reopens the trajectory `path` to append to it after a restart from the checkpoint of
    /// step `step`: frames of later steps (written after that checkpoint) are dropped, so
    /// the continued run does not repeat them. `step = u64::MAX` keeps every frame. The
    /// frames go on at the precision of the file's positions (f64 when it has none yet
    /// and schema 2.x).
    ///
    /// Errors: the file cannot be read or written, or is not a GSD trajectory.
    pub fn resume(path: impl AsRef<Path>, step: u64) -> Result<Self> {
        let read = GsdFile::open(&path)?;
        let mut keep = read.frames;
        for f in 0..read.frames {
            let s = read.chunk(f, "configuration/step")?;
            if s.and_then(|c| c.to_u64_scalar()).unwrap_or(0) > step {
                keep = f;
                break;
            }
        }
        let mut initial = Vec::new();
        if keep > 0 {
            let first: Vec<Entry> = read
                .entries
                .iter()
                .copied()
                .filter(|e| e.frame == 0)
                .collect();
            for e in first {
                let name = read.names[usize::from(e.id)].clone();
                let c = read.chunk(0, &name)?.expect("an indexed chunk");
                initial.push((e.id, c));
            }
        }
        let entries: Vec<Entry> = read
            .entries
            .iter()
            .copied()
            .filter(|e| e.frame < keep)
            .collect();
        let positions = read.chunk(0, "particles/position")?;
        let precision = match positions.map(|c| c.kind()) {
            Some(ChunkType::F64) => Precision::F64,
            Some(_) => Precision::F32,
            None if read.header.schema_version >> 16 >= 2 => Precision::F64,
            None => Precision::F32,
        };
        let (path, header, names) = (read.path, read.header, read.names);
        let mut w = Self::reopen(path, header, precision, names, entries, initial)?;
        let dropped = read.entries.len() - w.entries.len();
        if dropped > 0 {
            let at = w.header.index_location + (w.entries.len() * ENTRY) as u64;
            w.write_at(at, &vec![0u8; dropped * ENTRY])?;
            w.file.sync_data().map_err(|e| io_error(&w.path, &e))?;
        }
        Ok(w)
    }

    fn reopen(
        path: PathBuf,
        header: Header,
        precision: Precision,
        names: Vec<String>,
        entries: Vec<Entry>,
        initial: Vec<(u16, Chunk)>,
    ) -> Result<Self> {
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
            .map_err(|e| io_error(&path, &e))?;
        let names_used = names.iter().map(|n| n.len() as u64 + 1).sum();
        let frames = entries.last().map_or(0, |e| e.frame + 1);
        Ok(Self {
            file,
            path,
            header,
            precision,
            names,
            names_used,
            entries,
            frames,
            initial,
            sync: true,
            writes_left: None,
            failed: None,
        })
    }

    /// Whether every frame is synced to the disk (data before index; on by default). Off,
    /// a killed process still leaves every completed frame readable, a power failure may not.
    pub fn sync_each_frame(mut self, on: bool) -> Self {
        self.sync = on;
        self
    }

    /// Frames in the file.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Fault injection for tests: every write after the first `writes` fails, as if the
    /// process had died there (the file is left as such a crash would leave it).
    #[doc(hidden)]
    pub fn fail_after_writes(mut self, writes: u64) -> Self {
        self.writes_left = Some(writes);
        self
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends `frame` (see the [module docs](super) for the order of the writes).
    ///
    /// Errors: in an f32 trajectory, a value beyond the range of f32 (nothing is written;
    /// the writer goes on); a write failure or more than 65535 distinct chunk names (the
    /// file keeps every earlier frame; this writer refuses further frames: reopen with
    /// [`resume`](Self::resume)).
    pub fn push(&mut self, frame: &GsdFrame) -> Result<()> {
        if let Some(e) = &self.failed {
            return Err(Error::Io {
                path: self.path.display().to_string(),
                message: format!(
                    "an earlier frame failed to write ({e}); reopen the file with \
                     GsdWriter::resume to go on"
                ),
            });
        }
        // A frame that does not fit the precision is refused before anything is written.
        let chunks = frame.chunks(self.precision)?;
        let result = self.write_frame(chunks);
        if let Err(e) = &result {
            self.failed = Some(e.to_string());
        }
        result
    }

    fn write_at(&mut self, at: u64, bytes: &[u8]) -> Result<()> {
        if let Some(left) = self.writes_left.as_mut() {
            if *left == 0 {
                return Err(Error::Io {
                    path: self.path.display().to_string(),
                    message: "injected failure (GsdWriter::fail_after_writes)".into(),
                });
            }
            *left -= 1;
        }
        self.file
            .seek(SeekFrom::Start(at))
            .and_then(|_| self.file.write_all(bytes))
            .map_err(|e| io_error(&self.path, &e))
    }

    fn sync_if_asked(&mut self) -> Result<()> {
        if self.sync {
            self.file
                .sync_data()
                .map_err(|e| io_error(&self.path, &e))?;
        }
        Ok(())
    }

    fn write_frame(&mut self, frame: Vec<(String, Chunk)>) -> Result<()> {
        // Name ids (new names appended), chunks in id order, those equal to frame 0's left out.
        let first_new_name = self.names.len();
        // Particle chunks fall back to frame 0's only between frames of one particle count.
        let initial = |name: &str| {
            let id = self.names.iter().position(|n| n == name)?;
            let (_, c) = self.initial.iter().find(|(i, _)| usize::from(*i) == id)?;
            Some(c)
        };
        let count = frame
            .iter()
            .find(|(n, _)| n == "particles/N")
            .map(|(_, c)| c);
        let same_count = count == initial("particles/N");
        let mut chunks = Vec::new();
        for (name, chunk) in frame {
            let id = match self.names.iter().position(|n| *n == name) {
                Some(id) => id,
                None => {
                    self.names.push(name);
                    self.names.len() - 1
                }
            };
            let id = u16::try_from(id).map_err(|_| {
                Error::invalid(
                    "chunk names",
                    self.names.len(),
                    "a GSD file holds at most 65535 distinct names; log fewer quantities",
                )
            })?;
            // The step and the logged time series are written in every frame.
            let name = &self.names[usize::from(id)];
            let repeated = self.frames > 0
                && name_is_attribute(name)
                && inherits_from_frame_0(name, same_count)
                && self.initial.iter().any(|(i, c)| *i == id && *c == chunk);
            if !repeated {
                chunks.push((id, chunk));
            }
        }
        chunks.sort_by_key(|(id, _)| *id);
        let new_names: Vec<u8> = self.names[first_new_name..]
            .iter()
            .flat_map(|n| n.bytes().chain([0]))
            .collect();
        // The data, appended.
        let mut end = self
            .file
            .seek(SeekFrom::End(0))
            .map_err(|e| io_error(&self.path, &e))?;
        let mut data = Vec::with_capacity(chunks.iter().map(|(_, c)| c.bytes.len()).sum());
        let mut new_entries = Vec::with_capacity(chunks.len());
        for (id, c) in &chunks {
            new_entries.push(Entry {
                frame: self.frames,
                rows: c.rows,
                location: end + data.len() as u64,
                columns: c.columns,
                id: *id,
                kind: c.kind,
            });
            data.extend_from_slice(&c.bytes);
        }
        self.write_at(end, &data)?;
        end += data.len() as u64;
        // New names: in the free part of the list, or a larger list at the end of the file
        // (one NUL byte must stay free: it ends the list).
        let mut header = self.header;
        let used = self.names_used + new_names.len() as u64;
        if used < header.name_segments * NAME_SEGMENT {
            let at = header.names_location + self.names_used;
            self.write_at(at, &new_names)?;
        } else if !new_names.is_empty() {
            let segments = (2 * header.name_segments).max(used / NAME_SEGMENT + 1);
            let mut list: Vec<u8> = self
                .names
                .iter()
                .flat_map(|n| n.bytes().chain([0]))
                .collect();
            list.resize((segments * NAME_SEGMENT) as usize, 0);
            self.write_at(end, &list)?;
            header.names_location = end;
            header.name_segments = segments;
            end += list.len() as u64;
        }
        // The index entries: in the free slots, or all in a larger index at the end.
        let count = (self.entries.len() + new_entries.len()) as u64;
        let relocate = count > header.index_entries;
        if relocate {
            let capacity = (2 * header.index_entries).max(count);
            let mut index = vec![0u8; capacity as usize * ENTRY];
            for (slot, e) in index
                .chunks_exact_mut(ENTRY)
                .zip(self.entries.iter().chain(&new_entries))
            {
                slot.copy_from_slice(&e.to_bytes());
            }
            self.write_at(end, &index)?;
            header.index_location = end;
            header.index_entries = capacity;
        }
        self.sync_if_asked()?;
        if header != self.header {
            self.write_at(0, &header.to_bytes())?;
            self.header = header;
        }
        if !relocate {
            let bytes: Vec<u8> = new_entries.iter().flat_map(|e| e.to_bytes()).collect();
            let at = header.index_location + (self.entries.len() * ENTRY) as u64;
            self.write_at(at, &bytes)?;
        }
        self.sync_if_asked()?;
        self.names_used = used;
        if self.frames == 0 {
            self.initial = chunks;
        }
        self.entries.extend(new_entries);
        self.frames += 1;
        Ok(())
    }
}
