//! Atomic file writes: every file simkit writes (outputs, checkpoints) goes through here.
//!
//! Data is written to a temporary file in the target's directory (`.name.tmp-<pid>-<n>`),
//! flushed and synced, then renamed over the target. A reader therefore sees either the old
//! file or the complete new one, never a half-written file, and a failed write leaves the
//! previous file untouched and no temporary file behind. A writer killed before it
//! committed leaves its temporary file; [`remove_stale_temporaries`] removes those of a
//! target (checkpoint writes call it: they are rare, and a killed run is resumed from
//! them).

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::{Error, Result};

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// The hint for a path with a file where a directory should be.
const NOT_A_DIRECTORY: &str =
    "; a file stands where the path needs a directory: remove it or choose another path";

/// Converts an I/O error on `path` into [`Error::Io`], adding a hint for the usual
/// causes.
pub fn io_error(path: &Path, e: &io::Error) -> Error {
    let hint = match e.kind() {
        io::ErrorKind::PermissionDenied => "; check that the directory is writable",
        io::ErrorKind::NotFound => "; check that the path is valid",
        io::ErrorKind::StorageFull => "; free some disk space",
        io::ErrorKind::NotADirectory => NOT_A_DIRECTORY,
        io::ErrorKind::FileTooLarge => {
            "; the file-size limit was reached (ulimit -f, or the file system's): raise it or \
             write elsewhere"
        }
        _ => "",
    };
    Error::Io {
        path: path.display().to_string(),
        message: format!("{e}{hint}"),
    }
}

/// A file being written atomically: bytes go to a temporary sibling until
/// [`commit`](Self::commit) renames it over the target.
///
/// Dropping an `AtomicFile` without committing removes the temporary file and leaves the
/// target as it was. Implements [`Write`] (buffered); a failed write poisons the file so that
/// `commit` refuses to publish it.
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    tmp: PathBuf,
    writer: Option<BufWriter<File>>,
    failed: Option<String>,
}

impl AtomicFile {
    /// Starts writing `path`, creating its parent directories as needed.
    ///
    /// Errors when `path` has no file name or the temporary file cannot be created.
    pub fn create(path: impl AsRef<Path>) -> Result<Self> {
        let target = path.as_ref().to_path_buf();
        let name = target.file_name().ok_or_else(|| {
            Error::invalid(
                "path",
                target.display(),
                "has no file name; pass a file path such as out/field.png",
            )
        })?;
        let parent = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        fs::create_dir_all(&parent).map_err(|e| match e.kind() {
            // A file where a directory of the path should be.
            io::ErrorKind::AlreadyExists => Error::Io {
                path: parent.display().to_string(),
                message: format!("{e}{NOT_A_DIRECTORY}"),
            },
            _ => io_error(&parent, &e),
        })?;
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let mut tmp_name = temporary_prefix(name);
        tmp_name.push(format!("{}-{n}", std::process::id()));
        let tmp = parent.join(tmp_name);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| io_error(&tmp, &e))?;
        Ok(Self {
            target,
            tmp,
            writer: Some(BufWriter::with_capacity(1 << 16, file)),
            failed: None,
        })
    }

    /// The final path this file will be renamed to.
    pub fn path(&self) -> &Path {
        &self.target
    }

    /// Flushes, syncs and renames the temporary file over the target.
    ///
    /// Errors (and removes the temporary file) when an earlier write failed or the flush,
    /// sync or rename fails; the target is then left as it was.
    pub fn commit(mut self) -> Result<()> {
        if let Some(msg) = self.failed.take() {
            return Err(Error::Io {
                path: self.target.display().to_string(),
                message: format!("an earlier write failed ({msg}); the file was not replaced"),
            });
        }
        let Some(writer) = self.writer.take() else {
            return Err(Error::Io {
                path: self.target.display().to_string(),
                message: "file already committed".into(),
            });
        };
        let result = (|| -> io::Result<()> {
            let file = writer.into_inner().map_err(|e| e.into_error())?;
            file.sync_all()?;
            drop(file);
            fs::rename(&self.tmp, &self.target)
        })();
        match result {
            Ok(()) => {
                sync_parent_dir(&self.target);
                Ok(())
            }
            Err(e) => {
                let _ = fs::remove_file(&self.tmp);
                Err(io_error(&self.target, &e))
            }
        }
    }
}

/// The start of the temporary files' names of target file `name`: `.name.tmp-`.
fn temporary_prefix(name: &std::ffi::OsStr) -> std::ffi::OsString {
    let mut prefix = std::ffi::OsString::from(".");
    prefix.push(name);
    prefix.push(".tmp-");
    prefix
}

/// Removes the temporary files of `path` (`.name.tmp-<pid>-<n>` beside it) left by writers
/// that died before they committed (killed, or out of power): those whose process is gone.
/// Linux only (a process of this machine exists while `/proc/<pid>` does; elsewhere
/// nothing is removed); best effort, it lists the directory once.
pub fn remove_stale_temporaries(path: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Some(name) = path.file_name() else {
        return;
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let prefix = temporary_prefix(name);
    let (Some(prefix), Ok(entries)) = (prefix.to_str(), fs::read_dir(dir)) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(prefix))
            .and_then(|rest| rest.split_once('-'))
            .and_then(|(pid, _)| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = fs::remove_file(entry.path());
        }
    }
}

#[cfg(unix)]
fn sync_parent_dir(target: &Path) {
    if let Some(dir) = target.parent() {
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all(); // best effort: the data itself is already synced
        }
    }
}

#[cfg(not(unix))]
fn sync_parent_dir(_target: &Path) {}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let w = self
            .writer
            .as_mut()
            .ok_or_else(|| io::Error::other("file already committed"))?;
        w.write(buf).inspect_err(|e| {
            self.failed.get_or_insert_with(|| e.to_string());
        })
    }

    fn flush(&mut self) -> io::Result<()> {
        match self.writer.as_mut() {
            Some(w) => w.flush().inspect_err(|e| {
                self.failed.get_or_insert_with(|| e.to_string());
            }),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(w) = self.writer.take() {
            drop(w);
            let _ = fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `path` atomically with the bytes that `write` produces.
///
/// The closure gets a buffered writer to a temporary file. When it returns `Ok`, the file is
/// flushed, synced and renamed over `path`; when it returns `Err` (or any I/O step fails), the
/// temporary file is removed and a previous file at `path` stays intact. Parent directories
/// are created as needed.
///
/// ```
/// use std::io::Write;
/// # fn main() -> simkit_backend::Result<()> {
/// let path = std::env::temp_dir().join("simkit-doc-atomic").join("hello.txt");
/// simkit_backend::atomic::write_atomic(&path, |w| writeln!(w, "hello"))?;
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), "hello\n");
/// # Ok(())
/// # }
/// ```
pub fn write_atomic<F>(path: impl AsRef<Path>, write: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let mut file = AtomicFile::create(path)?;
    if let Err(e) = write(&mut file) {
        let err = io_error(file.path(), &e);
        drop(file);
        return Err(err);
    }
    file.commit()
}
