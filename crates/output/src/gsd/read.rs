//! [`GsdFile`]: a GSD file opened for reading, its index checked against its size.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::{
    Chunk, ChunkType, ENTRY, Entry, GSD_VERSION, GsdFrame, HEADER, Header, MAGIC, NAME_SEGMENT,
    inherits_from_frame_0, u64_at,
};
use crate::atomic::io_error;
use simkit_backend::{Error, Result};

/// A GSD file opened for reading; see the [module docs](super).
#[derive(Debug)]
pub struct GsdFile {
    file: File,
    pub(super) path: PathBuf,
    pub(super) header: Header,
    pub(super) names: Vec<String>,
    pub(super) entries: Vec<Entry>,
    pub(super) frames: u64,
}

impl GsdFile {
    /// Opens `path` and reads its header, name list and index (every entry checked against
    /// the file's size before anything is allocated from it).
    ///
    /// Errors: a file that cannot be read, is not a GSD file of file layer 2.x with the
    /// `hoomd` schema 1.x or 2.x, or whose index or name list is corrupt.
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let mut file = File::open(&path).map_err(|e| io_error(&path, &e))?;
        let len = file.metadata().map_err(|e| io_error(&path, &e))?.len();
        let corrupt = |reason: String| Error::Io {
            path: path.display().to_string(),
            message: format!("not a readable GSD trajectory: {reason}"),
        };
        if len < HEADER as u64 {
            return Err(corrupt(format!("{len} bytes, shorter than the header")));
        }
        let mut h = [0u8; HEADER];
        file.read_exact(&mut h).map_err(|e| io_error(&path, &e))?;
        if u64_at(&h, 0) != MAGIC {
            return Err(corrupt("no GSD magic number at the start".into()));
        }
        let version = u32::from_le_bytes(h[44..48].try_into().expect("4 bytes"));
        let schema_version = u32::from_le_bytes(h[40..44].try_into().expect("4 bytes"));
        let schema = &h[112..176];
        let schema = &schema[..schema.iter().position(|&b| b == 0).unwrap_or(64)];
        if version >> 16 != GSD_VERSION >> 16
            || schema != b"hoomd"
            || !(1..=2).contains(&(schema_version >> 16))
        {
            return Err(corrupt(format!(
                "file layer {}.{} with schema {:?} {}.{}; simkit reads file layer 2.x with \
                 schema hoomd 1.x or 2.x",
                version >> 16,
                version & 0xffff,
                String::from_utf8_lossy(schema),
                schema_version >> 16,
                schema_version & 0xffff
            )));
        }
        let header = Header {
            schema_version,
            index_location: u64_at(&h, 8),
            index_entries: u64_at(&h, 16),
            names_location: u64_at(&h, 24),
            name_segments: u64_at(&h, 32),
        };
        let block = |what: &str, at: u64, count: u64, size: u64| -> Result<usize> {
            let end = count.checked_mul(size).and_then(|b| b.checked_add(at));
            match end {
                Some(end) if end <= len && count > 0 => Ok((count * size) as usize),
                _ => Err(corrupt(format!(
                    "the {what} ({count} x {size} bytes at {at}) does not fit in the file's \
                     {len} bytes"
                ))),
            }
        };
        let names_bytes = block(
            "name list",
            header.names_location,
            header.name_segments,
            NAME_SEGMENT,
        )?;
        let index_bytes = block(
            "index",
            header.index_location,
            header.index_entries,
            ENTRY as u64,
        )?;
        let read = |file: &mut File, at: u64, bytes: usize| -> Result<Vec<u8>> {
            let mut buf = vec![0u8; bytes];
            file.seek(SeekFrom::Start(at))
                .and_then(|_| file.read_exact(&mut buf))
                .map_err(|e| io_error(&path, &e))?;
            Ok(buf)
        };
        let list = read(&mut file, header.names_location, names_bytes)?;
        if list.last() != Some(&0) {
            return Err(corrupt("the name list does not end in a NUL byte".into()));
        }
        let names: Vec<String> = list
            .split(|&b| b == 0)
            .take_while(|s| !s.is_empty())
            .map(|s| String::from_utf8_lossy(s).into_owned())
            .collect();
        let index = read(&mut file, header.index_location, index_bytes)?;
        let mut entries = Vec::new();
        for (k, b) in index.chunks_exact(ENTRY).enumerate() {
            let location = u64_at(b, 16);
            if location == 0 {
                break;
            }
            let kind = ChunkType::from_code(b[30]);
            let id = u16::from_le_bytes([b[28], b[29]]);
            let entry = kind.map(|kind| Entry {
                frame: u64_at(b, 0),
                rows: u64_at(b, 8),
                location,
                columns: u32::from_le_bytes(b[24..28].try_into().expect("4 bytes")),
                id,
                kind,
            });
            let fits = entry.is_some_and(|e| {
                e.rows
                    .checked_mul(u64::from(e.columns))
                    .and_then(|c| c.checked_mul(e.kind.size() as u64))
                    .and_then(|s| s.checked_add(e.location))
                    .is_some_and(|end| end <= len)
            });
            let ordered = entry.is_some_and(|e| {
                entries
                    .last()
                    .is_none_or(|p: &Entry| (p.frame, p.id) < (e.frame, e.id))
            });
            match entry {
                // A frame number beyond the index's size cannot be (each frame has an
                // entry): it bounds the frames a reader loops over.
                Some(e)
                    if fits
                        && ordered
                        && e.frame < header.index_entries
                        && usize::from(id) < names.len()
                        && b[31] == 0 =>
                {
                    entries.push(e)
                }
                _ => {
                    return Err(corrupt(format!(
                        "index entry {k} has a bad type, name, order or extent"
                    )));
                }
            }
        }
        let frames = entries.last().map_or(0, |e| e.frame + 1);
        Ok(Self {
            file,
            path,
            header,
            names,
            entries,
            frames,
        })
    }

    /// Number of frames.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Every chunk name in the file.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The chunk `name` of `frame`, if the frame has one (no fall-back to frame 0).
    ///
    /// Errors: a read failure.
    pub fn chunk(&self, frame: u64, name: &str) -> Result<Option<Chunk>> {
        let Some(id) = self.names.iter().position(|n| n == name) else {
            return Ok(None);
        };
        let key = (frame, id as u16);
        let Ok(at) = self.entries.binary_search_by_key(&key, |e| (e.frame, e.id)) else {
            return Ok(None);
        };
        let e = self.entries[at];
        let mut bytes = vec![0u8; e.size() as usize];
        let mut file = &self.file;
        file.seek(SeekFrom::Start(e.location))
            .and_then(|_| file.read_exact(&mut bytes))
            .map_err(|e| io_error(&self.path, &e))?;
        Ok(Some(Chunk {
            kind: e.kind,
            rows: e.rows,
            columns: e.columns,
            bytes,
        }))
    }

    /// Frame `i`, chunks it lacks taken from frame 0 as the schema says (particle chunks
    /// only when the two frames hold as many particles).
    ///
    /// Errors: `i` out of range, a read failure, or chunks of the wrong type or shape.
    pub fn frame(&self, i: u64) -> Result<GsdFrame> {
        if i >= self.frames {
            return Err(Error::invalid(
                "frame",
                i,
                format!("the file has {} frames", self.frames),
            ));
        }
        let logs: Vec<String> = self
            .entries
            .iter()
            .filter(|e| e.frame == i)
            .map(|e| self.names[usize::from(e.id)].clone())
            .filter(|n| n.starts_with("log/"))
            .collect();
        let mut log_chunks = Vec::new();
        for name in logs {
            let c = self.chunk(i, &name)?.expect("an indexed chunk");
            log_chunks.push((name, c));
        }
        // A particle chunk missing from frame i is frame 0's only when both frames have the
        // same particle count (else the schema's default).
        let count = |f: u64| -> Result<Option<Chunk>> { self.chunk(f, "particles/N") };
        let first = count(0)?;
        let same_count = count(i)?.is_none_or(|c| Some(c) == first);
        let mut get = |name: &str| -> Result<Option<Chunk>> {
            match self.chunk(i, name)? {
                Some(c) => Ok(Some(c)),
                None if inherits_from_frame_0(name, same_count) => self.chunk(0, name),
                None => Ok(None),
            }
        };
        GsdFrame::from_chunks(&mut get, log_chunks)
    }
}
