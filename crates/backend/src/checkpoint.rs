//! Checkpoints: the complete state of a simulation in one versioned, checksummed file, from
//! which a run resumes bit for bit.
//!
//! Every simkit simulation implements [`Restart`]: [`Restart::checkpoint`] returns the bytes,
//! [`Restart::resume`] rebuilds the simulation from them on any backend. A run of `2N` steps
//! and a run of `N` steps, checkpoint, resume (in a new process) and `N` more steps give
//! bit-identical states on the same backend: the payload holds everything that affects the
//! results (inputs, settings, positions, velocities, half-step quantities, counters, the
//! simulated time, everything that keys the random streams).
//!
//! # Format (version [`FORMAT_VERSION`])
//!
//! All integers little-endian:
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `SIMKITCK` |
//! | 4 | format version |
//! | 2 + n | producing package, UTF-8 (e.g. `simkit-dem`) |
//! | 2 + n | its version (e.g. `0.1.0`) |
//! | 2 + n | the model (e.g. `Dem<f64, 2>`) |
//! | 8 | payload length |
//! | n | payload: the crate's state in the [postcard](https://docs.rs/postcard) encoding (floats as their exact bits) |
//! | 4 | CRC-32 (IEEE) of every byte before it |
//!
//! A file of another format version, package version or model, a truncated or corrupt file
//! (checksum mismatch) gives [`Error::Checkpoint`] saying which; files are written
//! atomically (see [`crate::atomic`]).
//!
//! ```
//! use simkit_backend::checkpoint;
//! # fn main() -> simkit_backend::Result<()> {
//! let bytes = checkpoint::encode("simkit-demo", "1.0.0", "Demo", &(42u64, vec![0.5f64, -1.0]))?;
//! let (step, x): (u64, Vec<f64>) = checkpoint::decode(&bytes, "simkit-demo", "1.0.0", "Demo")?;
//! assert_eq!((step, x), (42, vec![0.5, -1.0]));
//! // One flipped bit anywhere is caught.
//! let mut bad = bytes.clone();
//! bad[30] ^= 1;
//! assert!(checkpoint::decode::<(u64, Vec<f64>)>(&bad, "simkit-demo", "1.0.0", "Demo").is_err());
//! # Ok(())
//! # }
//! ```

use std::io::Write;
use std::path::Path;

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::{Backend, Error, Precision, Result, Simulation};

/// The first eight bytes of every checkpoint.
pub const MAGIC: [u8; 8] = *b"SIMKITCK";
/// The version of the container layout described in the module docs.
pub const FORMAT_VERSION: u32 = 1;
/// Name used in errors for a checkpoint that came as bytes rather than from a file.
const IN_MEMORY: &str = "<bytes>";

/// A simulation that can be saved and resumed bit for bit.
pub trait Restart: Simulation + Sized {
    /// The complete state as checkpoint bytes (GPU backends download it).
    fn checkpoint(&mut self) -> Result<Vec<u8>>;

    /// Rebuilds the simulation from [`Restart::checkpoint`] bytes on `backend` (the inputs
    /// are validated again, as by the constructor).
    fn resume(bytes: &[u8], backend: Backend<'_>) -> Result<Self>;

    /// Writes [`Restart::checkpoint`] to `path` atomically (parent directories are created).
    fn write_checkpoint(&mut self, path: impl AsRef<Path>) -> Result<()> {
        let bytes = self.checkpoint()?;
        write_file(path, &bytes)
    }

    /// Reads a checkpoint file written by [`Restart::write_checkpoint`] and resumes from it;
    /// errors name the file.
    fn resume_file(path: impl AsRef<Path>, backend: Backend<'_>) -> Result<Self> {
        let path = path.as_ref();
        let bytes = read_file(path)?;
        Self::resume(&bytes, backend).map_err(|e| match e {
            Error::Checkpoint { reason, .. } => Error::Checkpoint {
                source_name: path.display().to_string(),
                reason,
            },
            other => other,
        })
    }
}

fn put_str(out: &mut Vec<u8>, s: &str) -> Result<()> {
    let len = u16::try_from(s.len())
        .map_err(|_| Error::invalid("checkpoint header field", s, "longer than 65535 bytes"))?;
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(s.as_bytes());
    Ok(())
}

/// Encodes `payload` in the checkpoint format, labelled with the producing `package`, its
/// `version` and the `model`.
pub fn encode<T: Serialize + ?Sized>(
    package: &str,
    version: &str,
    model: &str,
    payload: &T,
) -> Result<Vec<u8>> {
    let body = postcard::to_stdvec(payload)
        .map_err(|e| Error::checkpoint(format!("encoding the state of {model} failed: {e}")))?;
    let mut out = Vec::with_capacity(body.len() + 64);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    put_str(&mut out, package)?;
    put_str(&mut out, version)?;
    put_str(&mut out, model)?;
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&body);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    Ok(out)
}

/// Reads the fields of a checkpoint in order, failing with a "truncated" error.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let out = self.bytes.get(self.at..end)?;
        self.at = end;
        Some(out)
    }

    fn u16(&mut self) -> Option<u16> {
        Some(u16::from_le_bytes(self.take(2)?.try_into().ok()?))
    }

    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }

    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }

    fn str(&mut self) -> Option<String> {
        let n = usize::from(self.u16()?);
        Some(String::from_utf8_lossy(self.take(n)?).into_owned())
    }
}

/// The header fields of a checkpoint, as [`header`] reads them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Header {
    /// Container format version.
    pub format: u32,
    /// Producing package.
    pub package: String,
    /// Its version.
    pub version: String,
    /// The model.
    pub model: String,
}

/// Reads and checks the header and checksum of checkpoint `bytes` without decoding the
/// payload: which package, version and model wrote it. Errors for a file that is not a
/// checkpoint, is truncated, or fails its checksum.
pub fn header(bytes: &[u8]) -> Result<Header> {
    split(bytes, IN_MEMORY).map(|(h, _)| h)
}

pub(crate) fn split<'a>(bytes: &'a [u8], source: &str) -> Result<(Header, &'a [u8])> {
    let fail = |reason: String| Error::Checkpoint {
        source_name: source.to_string(),
        reason,
    };
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err(fail(
            "not a simkit checkpoint (the file does not start with SIMKITCK); pass a file \
             written by write_checkpoint"
                .into(),
        ));
    }
    let truncated = || {
        fail(format!(
            "truncated ({} bytes); the write was interrupted or the file was cut, use an \
             earlier checkpoint",
            bytes.len()
        ))
    };
    let mut r = Reader { bytes, at: 8 };
    let format = r.u32().ok_or_else(truncated)?;
    if format != FORMAT_VERSION {
        return Err(fail(format!(
            "container format version {format}, this build reads version {FORMAT_VERSION}; \
             resume with the simkit version that wrote it"
        )));
    }
    let package = r.str().ok_or_else(truncated)?;
    let version = r.str().ok_or_else(truncated)?;
    let model = r.str().ok_or_else(truncated)?;
    let len = r.u64().ok_or_else(truncated)?;
    let len = usize::try_from(len).map_err(|_| truncated())?;
    let payload = r.take(len).ok_or_else(truncated)?;
    let body_end = r.at;
    let stored = r.u32().ok_or_else(truncated)?;
    if r.at != bytes.len() {
        return Err(fail(format!(
            "{} bytes follow the checksum; the file is corrupt or two files were joined",
            bytes.len() - r.at
        )));
    }
    let crc = crc32fast::hash(&bytes[..body_end]);
    if crc != stored {
        return Err(fail(format!(
            "checksum mismatch (stored {stored:08x}, computed {crc:08x}): the file is corrupt; \
             use an earlier checkpoint"
        )));
    }
    Ok((
        Header {
            format,
            package,
            version,
            model,
        },
        payload,
    ))
}

/// Decodes checkpoint `bytes` written by [`encode`] for the same `package`, `version` and
/// `model`; any mismatch, truncation or corruption is an [`Error::Checkpoint`] saying which.
pub fn decode<T: DeserializeOwned>(
    bytes: &[u8],
    package: &str,
    version: &str,
    model: &str,
) -> Result<T> {
    decode_parts(bytes, package, version, Some(model)).map(|(_, payload)| payload)
}

/// [`decode`], with `model = None` accepting the model the header names.
fn decode_parts<T: DeserializeOwned>(
    bytes: &[u8],
    package: &str,
    version: &str,
    model: Option<&str>,
) -> Result<(String, T)> {
    let (h, payload) = split(bytes, IN_MEMORY)?;
    let fail = Error::checkpoint;
    let model = model.unwrap_or(&h.model);
    if h.package != package {
        return Err(fail(format!(
            "written by {} ({}), not {package}; resume it with that crate",
            h.package, h.model
        )));
    }
    if h.version != version {
        return Err(fail(format!(
            "written by {} {}, this is {package} {version}; resume with the version that wrote \
             it (the state layout may differ between versions)",
            h.package, h.version
        )));
    }
    if h.model != model {
        return Err(fail(format!(
            "holds a {} run, not {model}; resume it with the matching type",
            h.model
        )));
    }
    let payload = postcard::from_bytes(payload).map_err(|e| {
        fail(format!(
            "the payload does not decode as {model} ({e}) although its checksum matches; it \
             was written by an incompatible build"
        ))
    })?;
    Ok((h.model, payload))
}

/// Decodes checkpoint `bytes` of `package` and `version` whatever model the header names,
/// returning that model with the payload: for a crate whose model (precision, dimension,
/// backend) is read from the file and then checked against what the caller can resume.
/// Errors as [`decode`] for everything but the model.
pub fn decode_any_model<T: DeserializeOwned>(
    bytes: &[u8],
    package: &str,
    version: &str,
) -> Result<(String, T)> {
    decode_parts(bytes, package, version, None)
}

/// The backend part of a particle engine's model string: `gpu f32, {axes}` on the GPU
/// (which computes in `f32`), `cpu {precision}, {axes}` on the CPU (e.g. `cpu f64, 3`).
pub fn engine_kind(gpu: bool, precision: Precision, axes: usize) -> String {
    if gpu {
        format!("gpu f32, {axes}")
    } else {
        format!("cpu {}, {axes}", precision.wgsl())
    }
}

/// The model string of a run of a crate with pluggable laws: `{name}<{kind}>` for the
/// crate's default law, `{name}<{kind}, {law}>` for any other (e.g. `Md<cpu f64, 3>`,
/// `Md<gpu f32, 2, morse>`), so a run resumes only with the law that wrote it and the
/// default law's strings stay those of the crate before laws were pluggable.
pub fn model_with_law(name: &str, kind: &str, law: &str, default_law: &str) -> String {
    if law == default_law {
        format!("{name}<{kind}>")
    } else {
        format!("{name}<{kind}, {law}>")
    }
}

/// Checks a law's name for [`model_with_law`]: letters, digits, `-` and `_` only, and not
/// the default law's name unless `is_default` (the law is the default's type), so that
/// two laws never write the same model string.
///
/// Errors: [`Error::InvalidParameter`] naming the law's name and the fix.
pub fn check_law_name(name: &str, default_law: &str, is_default: bool) -> Result<()> {
    let ok = !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if !ok {
        return Err(Error::invalid(
            "law NAME",
            name,
            "must be non-empty, of letters, digits, '-' and '_' (checkpoints record it)",
        ));
    }
    if name == default_law && !is_default {
        return Err(Error::invalid(
            "law NAME",
            name,
            "is the built-in default law's name; give your law a name of its own (a \
             checkpoint of one would otherwise resume as the other)",
        ));
    }
    Ok(())
}

/// Refuses, before its payload is read, a checkpoint whose model string (of
/// [`model_with_law`]) names another law than `law`.
///
/// Errors: [`Error::Checkpoint`] naming both laws, and those of [`header`].
pub fn require_law(bytes: &[u8], law: &str, default_law: &str) -> Result<()> {
    let model = header(bytes)?.model;
    let inner = model
        .split_once('<')
        .map_or("", |(_, rest)| rest.trim_end_matches('>'));
    let written = inner.splitn(3, ", ").nth(2).unwrap_or(default_law);
    if written == law {
        return Ok(());
    }
    Err(Error::checkpoint(format!(
        "holds a {model} run of law '{written}', not '{law}'; resume it with the law type \
         that wrote it"
    )))
}

/// Writes checkpoint `bytes` to `path` atomically, creating parent directories; first
/// removes the temporary files of `path` that writers killed mid-write left
/// ([`crate::atomic::remove_stale_temporaries`]).
pub fn write_file(path: impl AsRef<Path>, bytes: &[u8]) -> Result<()> {
    crate::atomic::remove_stale_temporaries(path.as_ref());
    crate::atomic::write_atomic(path, |w: &mut dyn Write| w.write_all(bytes))
}

/// Reads a checkpoint file (errors name the path).
pub fn read_file(path: impl AsRef<Path>) -> Result<Vec<u8>> {
    let path = path.as_ref();
    std::fs::read(path).map_err(|e| crate::atomic::io_error(path, &e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<u8> {
        encode(
            "simkit-x",
            "0.1.0",
            "X<f64>",
            &(7u64, vec![1.5f64, f64::MIN_POSITIVE]),
        )
        .unwrap()
    }

    fn reason(e: Error) -> String {
        match e {
            Error::Checkpoint { reason, .. } => reason,
            other => panic!("expected a checkpoint error, got {other}"),
        }
    }

    #[test]
    fn a_law_in_the_model_string_is_checked_before_the_payload() {
        assert_eq!(engine_kind(false, Precision::F64, 3), "cpu f64, 3");
        assert_eq!(engine_kind(true, Precision::F64, 2), "gpu f32, 2");
        let m = model_with_law("Md", "cpu f64, 3", "morse", "lj");
        assert_eq!(m, "Md<cpu f64, 3, morse>");
        assert_eq!(
            model_with_law("Md", "cpu f64, 3", "lj", "lj"),
            "Md<cpu f64, 3>"
        );
        let bytes = encode("simkit-md", "0.1.0", &m, &1u8).unwrap();
        require_law(&bytes, "morse", "lj").unwrap();
        let e = require_law(&bytes, "lj", "lj").unwrap_err();
        assert!(e.to_string().contains("'morse'"), "{e}");
        check_law_name("morse", "lj", false).unwrap();
        assert!(check_law_name("lj", "lj", false).is_err());
        check_law_name("lj", "lj", true).unwrap();
        assert!(check_law_name("a, b", "lj", false).is_err());
        assert!(check_law_name("", "lj", false).is_err());
        let plain = encode("simkit-md", "0.1.0", "Md<cpu f64, 3>", &1u8).unwrap();
        require_law(&plain, "lj", "lj").unwrap();
        assert!(require_law(&plain, "morse", "lj").is_err());
    }

    #[test]
    fn round_trip_keeps_every_bit() {
        let v: (u64, Vec<f64>) = decode(&sample(), "simkit-x", "0.1.0", "X<f64>").unwrap();
        assert_eq!(v.0, 7);
        assert_eq!(v.1[1].to_bits(), f64::MIN_POSITIVE.to_bits());
        let h = header(&sample()).unwrap();
        assert_eq!((h.format, h.model.as_str()), (FORMAT_VERSION, "X<f64>"));
    }

    #[test]
    fn mismatches_and_damage_are_named() {
        let b = sample();
        let d = |bytes: &[u8], p: &str, v: &str, m: &str| {
            reason(decode::<(u64, Vec<f64>)>(bytes, p, v, m).unwrap_err())
        };
        assert!(d(&b, "simkit-y", "0.1.0", "X<f64>").contains("not simkit-y"));
        assert!(d(&b, "simkit-x", "0.2.0", "X<f64>").contains("0.1.0"));
        assert!(d(&b, "simkit-x", "0.1.0", "X<f32>").contains("X<f64>"));
        assert!(d(&b[..b.len() - 1], "simkit-x", "0.1.0", "X<f64>").contains("truncated"));
        assert!(d(b"hello", "simkit-x", "0.1.0", "X<f64>").contains("not a simkit checkpoint"));
        let mut v2 = b.clone();
        v2[8] = 2;
        assert!(d(&v2, "simkit-x", "0.1.0", "X<f64>").contains("format version 2"));
        // Every single-bit flip after the magic and format is caught, by the checksum or
        // the header checks, never decoded as a valid state.
        for i in 12..b.len() {
            for bit in 0..8 {
                let mut c = b.clone();
                c[i] ^= 1 << bit;
                assert!(decode::<(u64, Vec<f64>)>(&c, "simkit-x", "0.1.0", "X<f64>").is_err());
            }
        }
        let mut longer = b.clone();
        longer.push(0);
        assert!(d(&longer, "simkit-x", "0.1.0", "X<f64>").contains("follow the checksum"));
    }

    #[test]
    fn files_are_written_and_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a").join("run.ckpt");
        write_file(&path, &sample()).unwrap();
        assert_eq!(read_file(&path).unwrap(), sample());
        let e = read_file(dir.path().join("missing.ckpt")).unwrap_err();
        assert!(e.to_string().contains("missing.ckpt"), "{e}");
    }
}
