//! [`GsdFrame`]: one frame, checked when built, and its chunks.

use super::{Chunk, ChunkType};
use crate::vtk::check_interleaved;
use simkit_backend::particles::State;
use simkit_backend::{Error, Precision, Result, require_finite, require_positive};

/// A `log/` quantity of a frame: name (after `log/`), columns, values.
#[derive(Debug, Clone, PartialEq)]
struct Log {
    name: String,
    columns: u32,
    values: Vec<f64>,
}

/// One frame of a GSD trajectory; see the [module docs](super).
#[derive(Debug, Clone, PartialEq)]
pub struct GsdFrame {
    step: u64,
    dimensions: u8,
    box_: [f64; 6],
    positions: Vec<f64>,
    velocities: Option<Vec<f64>>,
    type_names: Vec<String>,
    type_ids: Option<Vec<u32>>,
    diameters: Option<Vec<f64>>,
    masses: Option<Vec<f64>>,
    logs: Vec<Log>,
}

/// The floats `values` as a chunk of `columns` columns at `precision`; in f32, a value
/// beyond its range is an error naming `name[i]`.
fn float_chunk(name: &str, columns: u32, values: &[f64], precision: Precision) -> Result<Chunk> {
    if precision == Precision::F64 {
        return Ok(Chunk::from_f64(columns, values));
    }
    let narrow: Vec<f32> = values.iter().map(|&v| v as f32).collect();
    if let Some(i) = narrow.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            format!("{name}[{i}]"),
            values[i],
            "beyond the range of the f32 trajectory (|x| < 3.4e38); write it in f64",
        ));
    }
    Ok(Chunk::from_f32(columns, &narrow))
}

/// Interleaved `values` with `dim` components each as three per item (`z = 0` in 2D),
/// `shift` subtracted; a value that is not finite is an error naming `what[i].axis`.
fn widen<T: Copy + Into<f64>>(
    what: &str,
    values: &[T],
    dim: usize,
    shift: [f64; 3],
) -> Result<Vec<f64>> {
    let mut out = Vec::with_capacity(values.len() / dim * 3);
    for (i, p) in values.chunks_exact(dim).enumerate() {
        for (a, &v) in p.iter().enumerate() {
            let v = require_finite(&format!("{what}[{i}].{}", AXES[a]), v.into())?;
            out.push(v - shift[a]);
        }
        if dim == 2 {
            out.push(0.0);
        }
    }
    Ok(out)
}

/// `values` rounded to f32 and back.
fn round_f32(values: &[f64]) -> Vec<f64> {
    values.iter().map(|&x| f64::from(x as f32)).collect()
}

const AXES: [&str; 3] = ["x", "y", "z"];

impl GsdFrame {
    /// A frame at time step `step` of particles at interleaved `positions` with `dim` (2 or
    /// 3) coordinates each, in the simulation box `[lo, hi]` (`dim` values each; stored
    /// relative to the box centre, see the [module docs](super)).
    ///
    /// Errors: `dim` not 2 or 3, a length that is not a multiple of `dim`, `lo` or `hi` of
    /// another length, `hi <= lo` or not finite on an axis, a coordinate that is not
    /// finite.
    pub fn new<T: Copy + Into<f64>>(
        step: u64,
        positions: &[T],
        dim: usize,
        lo: &[f64],
        hi: &[f64],
    ) -> Result<Self> {
        if dim != 2 && dim != 3 {
            return Err(Error::invalid("dim", dim, "GSD frames are 2D or 3D"));
        }
        check_interleaved(positions.len(), dim)?;
        for (what, b) in [("lo", lo), ("hi", hi)] {
            if b.len() != dim {
                return Err(Error::invalid(
                    format!("{what}.len()"),
                    b.len(),
                    format!("expected one box bound per axis ({dim})"),
                ));
            }
        }
        let mut box_ = [0.0; 6];
        let mut centre = [0.0; 3];
        for a in 0..dim {
            let name = || format!("hi[{a}] - lo[{a}]");
            let length = hi[a] - lo[a];
            if !length.is_finite() || length <= 0.0 {
                return Err(Error::invalid(
                    name(),
                    length,
                    "the box needs hi > lo (finite) on every axis",
                ));
            }
            box_[a] = length;
            centre[a] = 0.5 * (lo[a] + hi[a]);
        }
        let pos = widen("position", positions, dim, centre)?;
        Ok(Self {
            step,
            dimensions: dim as u8,
            box_,
            positions: pos,
            velocities: None,
            type_names: Vec::new(),
            type_ids: None,
            diameters: None,
            masses: None,
            logs: Vec::new(),
        })
    }

    /// A frame of a particle simulation's [`State`] at time step `step`, in the box
    /// `[lo, hi]` with `lo.len()` (2 or 3) axes: positions, velocities and, when the
    /// particles spin, `log/particles/angular_velocity` (three components, `[0, 0, w_z]`
    /// in 2D). Types, diameters and masses are the caller's to add.
    ///
    /// Errors: as [`new`](Self::new) and [`velocities`](Self::velocities).
    pub fn from_state(step: u64, state: &State, lo: &[f64], hi: &[f64]) -> Result<Self> {
        let dim = lo.len();
        let cut = |v: &[[f64; 3]]| -> Vec<f64> {
            v.iter().flat_map(|p| p[..dim.min(3)].to_vec()).collect()
        };
        let mut frame = Self::new(step, &cut(&state.positions), dim, lo, hi)?;
        frame.velocities(&cut(&state.velocities), dim)?;
        if !state.angular_velocities.is_empty() {
            let w = state.angular_velocities.as_flattened();
            frame.log("particles/angular_velocity", w, 3)?;
        }
        Ok(frame)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len() / 3
    }

    /// Whether the frame has no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Sets the velocities, interleaved with `dim` components each (the frame's dimension).
    ///
    /// Errors: another `dim` or length, a value that is not finite.
    pub fn velocities<T: Copy + Into<f64>>(&mut self, v: &[T], dim: usize) -> Result<&mut Self> {
        if dim != usize::from(self.dimensions) || v.len() != dim * self.len() {
            return Err(Error::invalid(
                "velocities",
                format!("{} values of dimension {dim}", v.len()),
                format!(
                    "expected {} values, {} per particle",
                    usize::from(self.dimensions) * self.len(),
                    self.dimensions
                ),
            ));
        }
        let out = widen("velocity", v, dim, [0.0; 3])?;
        self.velocities = Some(out);
        Ok(self)
    }

    /// Sets the species: particle `i` has type `ids[i]`, named `names[ids[i]]`.
    ///
    /// Errors: a length other than the particle count, an index out of range, a name that
    /// is empty, holds a NUL byte, or appears twice.
    pub fn types<K: Copy + Into<u32>, S: AsRef<str>>(
        &mut self,
        ids: &[K],
        names: &[S],
    ) -> Result<&mut Self> {
        self.check_len("type ids", ids.len())?;
        for (k, s) in names.iter().enumerate() {
            let s = s.as_ref();
            if s.is_empty() || s.contains('\0') {
                return Err(Error::invalid(
                    format!("names[{k}]"),
                    format!("{s:?}"),
                    "type names must be non-empty and hold no NUL byte",
                ));
            }
            if names[..k].iter().any(|o| o.as_ref() == s) {
                return Err(Error::invalid(
                    format!("names[{k}]"),
                    s,
                    "type names must be distinct",
                ));
            }
        }
        let ids: Vec<u32> = ids.iter().map(|&k| k.into()).collect();
        if let Some((i, k)) = ids
            .iter()
            .enumerate()
            .find(|(_, k)| **k as usize >= names.len())
        {
            return Err(Error::invalid(
                format!("ids[{i}]"),
                k,
                format!("only {} type names were given", names.len()),
            ));
        }
        self.type_ids = Some(ids);
        self.type_names = names.iter().map(|s| s.as_ref().to_string()).collect();
        Ok(self)
    }

    /// Sets the diameters (OVITO draws them; HOOMD's default is 1).
    ///
    /// Errors: a length other than the particle count, or a diameter that is not finite
    /// and positive.
    pub fn diameters(&mut self, d: &[f64]) -> Result<&mut Self> {
        self.diameters = Some(self.positive("diameter", d)?);
        Ok(self)
    }

    /// Sets the masses (HOOMD's default is 1).
    ///
    /// Errors: as [`diameters`](Self::diameters).
    pub fn masses(&mut self, m: &[f64]) -> Result<&mut Self> {
        self.masses = Some(self.positive("mass", m)?);
        Ok(self)
    }

    /// Adds a quantity `log/{name}` of `values.len() / columns` rows (one per particle for
    /// a per-particle quantity such as `particles/angular_velocity`, one for a global one
    /// such as `energy/kinetic`), stored as f64. `gsd.hoomd` returns it in `frame.log`
    /// under `name`.
    ///
    /// Errors: an empty name or one with a NUL byte, a name given twice, zero columns, a
    /// length that is not a multiple of `columns`, a value that is not finite.
    pub fn log(&mut self, name: &str, values: &[f64], columns: usize) -> Result<&mut Self> {
        if name.is_empty() || name.contains('\0') || self.logs.iter().any(|l| l.name == name) {
            return Err(Error::invalid(
                "log name",
                format!("{name:?}"),
                "expected a new, non-empty name without NUL bytes",
            ));
        }
        let columns32 = u32::try_from(columns).ok().filter(|&c| c > 0);
        let Some(columns32) = columns32.filter(|_| values.len().is_multiple_of(columns)) else {
            return Err(Error::invalid(
                format!("log {name}: columns"),
                columns,
                format!("expected a positive divisor of the {} values", values.len()),
            ));
        };
        for (i, &v) in values.iter().enumerate() {
            require_finite(&format!("log {name}[{i}]"), v)?;
        }
        self.logs.push(Log {
            name: name.to_string(),
            columns: columns32,
            values: values.to_vec(),
        });
        Ok(self)
    }

    fn check_len(&self, what: &str, len: usize) -> Result<()> {
        if len == self.len() {
            Ok(())
        } else {
            Err(Error::invalid(
                format!("{what}.len()"),
                len,
                format!("expected one per particle ({})", self.len()),
            ))
        }
    }

    fn positive(&self, what: &str, values: &[f64]) -> Result<Vec<f64>> {
        self.check_len(what, values.len())?;
        for (i, &v) in values.iter().enumerate() {
            require_positive(&format!("{what}[{i}]"), v)?;
        }
        Ok(values.to_vec())
    }

    /// The frame as a file of `precision` holds it, read back: in f32 every position,
    /// velocity, box length, diameter and mass rounded to f32 (`log/` arrays are f64 in
    /// either).
    ///
    /// Errors: in f32, a value beyond its range.
    pub fn rounded(&self, precision: Precision) -> Result<Self> {
        if precision == Precision::F64 {
            return Ok(self.clone());
        }
        self.chunks(precision)?;
        let mut r = self.clone();
        r.box_ = self.box_.map(|x| f64::from(x as f32));
        r.positions = round_f32(&self.positions);
        r.velocities = self.velocities.as_deref().map(round_f32);
        r.diameters = self.diameters.as_deref().map(round_f32);
        r.masses = self.masses.as_deref().map(round_f32);
        Ok(r)
    }

    /// The time step.
    pub fn step(&self) -> u64 {
        self.step
    }
    /// 2 or 3.
    pub fn dimensions(&self) -> usize {
        usize::from(self.dimensions)
    }
    /// The box as stored: `[Lx, Ly, Lz, xy, xz, yz]` (`Lz = 0` in 2D; no tilt).
    pub fn box_(&self) -> [f64; 6] {
        self.box_
    }
    /// Positions relative to the box centre, three per particle (`z = 0` in 2D).
    pub fn positions(&self) -> &[f64] {
        &self.positions
    }
    /// Velocities, three per particle, if set.
    pub fn velocity(&self) -> Option<&[f64]> {
        self.velocities.as_deref()
    }
    /// Type names (empty if no types were set).
    pub fn type_names(&self) -> &[String] {
        &self.type_names
    }
    /// Type index per particle, if set.
    pub fn type_ids(&self) -> Option<&[u32]> {
        self.type_ids.as_deref()
    }
    /// Diameters, if set.
    pub fn diameter(&self) -> Option<&[f64]> {
        self.diameters.as_deref()
    }
    /// Masses, if set.
    pub fn mass(&self) -> Option<&[f64]> {
        self.masses.as_deref()
    }
    /// The values of `log/{name}`, if set.
    pub fn logged(&self, name: &str) -> Option<&[f64]> {
        let l = self.logs.iter().find(|l| l.name == name)?;
        Some(&l.values)
    }

    /// The frame as named chunks, floats at `precision`.
    ///
    /// Errors: in f32, a value beyond its range.
    pub(super) fn chunks(&self, precision: Precision) -> Result<Vec<(String, Chunk)>> {
        let n = self.len() as u32;
        let floats = |name: &str, columns, values: &[f64]| {
            let chunk = float_chunk(name, columns, values, precision)?;
            Ok::<_, Error>((name.to_string(), chunk))
        };
        let mut out = vec![
            (
                "configuration/step".to_string(),
                Chunk::new(ChunkType::U64, 1, self.step.to_le_bytes().into_iter()),
            ),
            (
                "configuration/dimensions".into(),
                Chunk::new(ChunkType::U8, 1, std::iter::once(self.dimensions)),
            ),
            floats("configuration/box", 1, &self.box_)?,
            ("particles/N".into(), Chunk::from_u32(&[n])),
            floats("particles/position", 3, &self.positions)?,
        ];
        if let Some(v) = &self.velocities {
            out.push(floats("particles/velocity", 3, v)?);
        }
        if let Some(ids) = &self.type_ids {
            let width = self.type_names.iter().map(String::len).max().unwrap_or(0) + 1;
            let mut bytes = vec![0u8; width * self.type_names.len()];
            for (row, name) in bytes.chunks_exact_mut(width).zip(&self.type_names) {
                row[..name.len()].copy_from_slice(name.as_bytes());
            }
            let types = Chunk::new(ChunkType::I8, width as u32, bytes.into_iter());
            out.push(("particles/types".into(), types));
            out.push(("particles/typeid".into(), Chunk::from_u32(ids)));
        }
        if let Some(d) = &self.diameters {
            out.push(floats("particles/diameter", 1, d)?);
        }
        if let Some(m) = &self.masses {
            out.push(floats("particles/mass", 1, m)?);
        }
        for l in &self.logs {
            let chunk = Chunk::from_f64(l.columns, &l.values);
            out.push((format!("log/{}", l.name), chunk));
        }
        Ok(out)
    }

    /// Rebuilds a frame from its chunks (`get` returns frame 0's where the frame has none).
    pub(super) fn from_chunks(
        get: &mut dyn FnMut(&str) -> Result<Option<Chunk>>,
        logs: Vec<(String, Chunk)>,
    ) -> Result<Self> {
        let bad = |name: &str, c: &Chunk| {
            Error::invalid(
                format!("GSD chunk {name}"),
                format!("{:?} {} x {}", c.kind, c.rows, c.columns),
                "not the shape or type of the hoomd schema; not a trajectory simkit can read",
            )
        };
        let step = match get("configuration/step")? {
            Some(c) => c
                .to_u64_scalar()
                .ok_or_else(|| bad("configuration/step", &c))?,
            None => 0,
        };
        let dimensions = match get("configuration/dimensions")? {
            Some(c) if c.kind == ChunkType::U8 && matches!(c.bytes[..], [2] | [3]) => c.bytes[0],
            Some(c) => return Err(bad("configuration/dimensions", &c)),
            None => 3,
        };
        let box_ = match get("configuration/box")? {
            Some(c) => {
                let v = c.to_f64().filter(|v| v.len() == 6);
                let v = v.ok_or_else(|| bad("configuration/box", &c))?;
                [v[0], v[1], v[2], v[3], v[4], v[5]]
            }
            None => [1.0, 1.0, 1.0, 0.0, 0.0, 0.0],
        };
        let n = match get("particles/N")? {
            Some(c) => match c.to_u32().as_deref() {
                Some(&[n]) => n as usize,
                _ => return Err(bad("particles/N", &c)),
            },
            None => 0,
        };
        let mut floats = |name: &str, columns: u32| -> Result<Option<Vec<f64>>> {
            let Some(c) = get(name)? else {
                return Ok(None);
            };
            match c
                .to_f64()
                .filter(|_| matches!(c.kind, ChunkType::F32 | ChunkType::F64))
            {
                Some(v) if c.columns == columns && c.rows == n as u64 => Ok(Some(v)),
                _ => Err(bad(name, &c)),
            }
        };
        let positions = floats("particles/position", 3)?.unwrap_or_else(|| vec![0.0; 3 * n]);
        let velocities = floats("particles/velocity", 3)?;
        let diameters = floats("particles/diameter", 1)?;
        let masses = floats("particles/mass", 1)?;
        let mut type_names = Vec::new();
        let type_ids = match get("particles/typeid")? {
            Some(c) => {
                let ids = c.to_u32().filter(|v| v.len() == n);
                Some(ids.ok_or_else(|| bad("particles/typeid", &c))?)
            }
            None => None,
        };
        if let Some(c) = get("particles/types")? {
            if c.kind != ChunkType::I8 || c.columns == 0 {
                return Err(bad("particles/types", &c));
            }
            for row in c.bytes.chunks_exact(c.columns as usize) {
                let end = row.iter().position(|&b| b == 0).unwrap_or(row.len());
                let name =
                    std::str::from_utf8(&row[..end]).map_err(|_| bad("particles/types", &c))?;
                type_names.push(name.to_string());
            }
        }
        let logs = logs
            .into_iter()
            .map(|(name, c)| {
                let values = c.to_f64().ok_or_else(|| bad(&name, &c))?;
                let name = name.strip_prefix("log/").unwrap_or(&name).to_string();
                let columns = c.columns;
                Ok(Log {
                    name,
                    columns,
                    values,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            step,
            dimensions,
            box_,
            positions,
            velocities,
            type_names,
            type_ids,
            diameters,
            masses,
            logs,
        })
    }
}
