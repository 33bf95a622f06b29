//! Extended XYZ trajectories that ASE (`ase.io.read`) and OVITO read.
//!
//! Each frame is a particle count line, a comment line such as
//! `Lattice="10 0 0 0 10 0 0 0 1" Properties=species:S:1:pos:R:3:Radius:R:1 Time=0.5 pbc="T T F"`
//! and one line per particle. 2D positions are written with `z = 0`. Non-finite values are
//! rejected because readers cannot parse them.
//!
//! Species: ASE reads the `species` column as chemical symbols, so it holds element symbols
//! only (or `X`, ASE's dummy atom, the default). Simulations whose species are not chemical
//! elements use [`XyzFrame::kinds`]: species index `k` is written as the element with atomic
//! number `k + 1` (`H`, `He`, `Li`, ...), and the simulation's own name of the species goes
//! into a string column `kind` (ASE: `atoms.arrays["kind"]`; OVITO: a typed property).
//!
//! Property names: [`XyzFrame::velocities`] writes the extended XYZ name `velo` and
//! [`XyzFrame::radii`] OVITO's standard name `Radius`; OVITO (checked with 3.17) maps them to
//! its `Velocity` and `Radius` (drawn size) properties. A 3-column `Velocity` column is not a
//! safe alternative: that OVITO version reads its three columns into the x component. ASE,
//! which has no velocity column of its own (it stores momenta), keeps them as
//! `atoms.arrays["velo"]` and `atoms.arrays["Radius"]`.
//!
//! ```
//! use simkit_output::xyz::{XyzFrame, XyzWriter};
//! # fn main() -> simkit_backend::Result<()> {
//! let path = std::env::temp_dir().join("simkit-doc-xyz").join("traj.xyz");
//! let mut traj = XyzWriter::create(&path)?;
//! for step in 0..3 {
//!     let t = step as f64 * 0.1;
//!     let mut f = XyzFrame::from_xy(&[[t, 0.0], [1.0, t]])?;
//!     // Species 0 ("solid") is written as H, species 1 ("gas") as He.
//!     f.kinds(&[0u32, 1], &["solid", "gas"])?.box_2d(4.0, 4.0)?.time(t)?;
//!     f.radii(&[0.5, 0.25])?;
//!     traj.push(&f)?;
//! }
//! traj.finish()?; // renamed into place here
//! # Ok(())
//! # }
//! ```

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use crate::atomic::{AtomicFile, io_error, write_atomic};
use crate::numfmt;
use crate::vtk::check_interleaved;
use simkit_backend::{Error, Result};

/// Comment-line keys that [`XyzFrame`] writes itself.
const RESERVED_KEYS: [&str; 4] = ["Lattice", "Properties", "Time", "pbc"];

/// Column names that [`XyzFrame`] writes itself.
const RESERVED_COLUMNS: [&str; 3] = ["species", "pos", "kind"];

/// The chemical elements by atomic number `Z` (index `Z - 1`): the symbols ASE accepts in the
/// `species` column, and the symbols [`XyzFrame::kinds`] writes for species indices.
pub const ELEMENTS: [&str; 118] = [
    "H", "He", "Li", "Be", "B", "C", "N", "O", "F", "Ne", "Na", "Mg", "Al", "Si", "P", "S", "Cl",
    "Ar", "K", "Ca", "Sc", "Ti", "V", "Cr", "Mn", "Fe", "Co", "Ni", "Cu", "Zn", "Ga", "Ge", "As",
    "Se", "Br", "Kr", "Rb", "Sr", "Y", "Zr", "Nb", "Mo", "Tc", "Ru", "Rh", "Pd", "Ag", "Cd", "In",
    "Sn", "Sb", "Te", "I", "Xe", "Cs", "Ba", "La", "Ce", "Pr", "Nd", "Pm", "Sm", "Eu", "Gd", "Tb",
    "Dy", "Ho", "Er", "Tm", "Yb", "Lu", "Hf", "Ta", "W", "Re", "Os", "Ir", "Pt", "Au", "Hg", "Tl",
    "Pb", "Bi", "Po", "At", "Rn", "Fr", "Ra", "Ac", "Th", "Pa", "U", "Np", "Pu", "Am", "Cm", "Bk",
    "Cf", "Es", "Fm", "Md", "No", "Lr", "Rf", "Db", "Sg", "Bh", "Hs", "Mt", "Ds", "Rg", "Cn", "Nh",
    "Fl", "Mc", "Lv", "Ts", "Og",
];

#[derive(Debug, Clone, PartialEq)]
struct Column {
    name: String,
    components: usize,
    data: Vec<f64>,
}

/// One frame of an extended XYZ file; see the [module docs](self).
#[derive(Debug, Clone, PartialEq)]
pub struct XyzFrame {
    positions: Vec<f64>,
    species: Vec<String>,
    kind_names: Option<Vec<String>>,
    columns: Vec<Column>,
    lattice: Option<[[f64; 3]; 3]>,
    pbc: Option<[bool; 3]>,
    time: Option<f64>,
    info: Vec<(String, String)>,
}

impl XyzFrame {
    /// A frame from interleaved positions with `dim` (2 or 3) coordinates per particle.
    /// Every particle starts with species `X` (ASE's dummy atom).
    pub fn new<T: Copy + Into<f64>>(positions: &[T], dim: usize) -> Result<Self> {
        check_interleaved(positions.len(), dim)?;
        let n = positions.len() / dim;
        let mut pos = Vec::with_capacity(n * 3);
        for (i, p) in positions.chunks_exact(dim).enumerate() {
            for (k, &v) in p.iter().enumerate() {
                let v: f64 = v.into();
                finite(&format!("position[{i}].{}", ["x", "y", "z"][k]), v)?;
                pos.push(v);
            }
            if dim == 2 {
                pos.push(0.0);
            }
        }
        Ok(Self {
            positions: pos,
            species: vec!["X".into(); n],
            kind_names: None,
            columns: Vec::new(),
            lattice: None,
            pbc: None,
            time: None,
            info: Vec::new(),
        })
    }

    /// A frame from 2D points (`z = 0`).
    pub fn from_xy(points: &[[f64; 2]]) -> Result<Self> {
        Self::new(points.as_flattened(), 2)
    }

    /// A frame from 3D points.
    pub fn from_xyz(points: &[[f64; 3]]) -> Result<Self> {
        Self::new(points.as_flattened(), 3)
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len() / 3
    }

    /// Whether the frame has no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Sets one element symbol per particle (`H`, `Ar`, ..., from [`ELEMENTS`], or `X`).
    /// Removes any names set with [`kinds`](Self::kinds).
    ///
    /// Errors: a length other than the particle count, or a name that is not an element
    /// symbol (use [`kinds`](Self::kinds) for species that are not chemical elements).
    pub fn species<S: AsRef<str>>(&mut self, names: &[S]) -> Result<&mut Self> {
        if names.len() != self.len() {
            return Err(Error::invalid(
                "species.len()",
                names.len(),
                format!("expected one name per particle ({})", self.len()),
            ));
        }
        for (i, s) in names.iter().enumerate() {
            check_element(&format!("species[{i}]"), s.as_ref())?;
        }
        self.species = names.iter().map(|s| s.as_ref().to_string()).collect();
        self.kind_names = None;
        Ok(self)
    }

    /// Gives every particle the same element symbol (see [`species`](Self::species)).
    pub fn uniform_species(&mut self, name: &str) -> Result<&mut Self> {
        check_element("species", name)?;
        self.species = vec![name.to_string(); self.len()];
        self.kind_names = None;
        Ok(self)
    }

    /// Sets species that are not chemical elements: `kinds[i]` is particle `i`'s species
    /// index into `names`. Index `k` is written in the `species` column as the element with
    /// atomic number `k + 1` ([`ELEMENTS`]`[k]`: `H`, `He`, `Li`, ...), the same for every
    /// frame, and `names[k]` in a string column `kind`.
    ///
    /// Errors: a length other than the particle count, more names than [`ELEMENTS`], a name
    /// that is empty or holds whitespace, control characters or quotes, or an index out of
    /// range.
    pub fn kinds<K: Copy + Into<u32>, S: AsRef<str>>(
        &mut self,
        kinds: &[K],
        names: &[S],
    ) -> Result<&mut Self> {
        if kinds.len() != self.len() {
            return Err(Error::invalid(
                "kinds.len()",
                kinds.len(),
                format!("expected one species index per particle ({})", self.len()),
            ));
        }
        if names.len() > ELEMENTS.len() {
            return Err(Error::invalid(
                "names.len()",
                names.len(),
                format!(
                    "at most {} species map to distinct element symbols",
                    ELEMENTS.len()
                ),
            ));
        }
        for (k, s) in names.iter().enumerate() {
            check_word(&format!("names[{k}]"), s.as_ref())?;
        }
        let mut species = Vec::with_capacity(kinds.len());
        let mut kind_names = Vec::with_capacity(kinds.len());
        for (i, &k) in kinds.iter().enumerate() {
            let k: u32 = k.into();
            let name = names.get(k as usize).ok_or_else(|| {
                Error::invalid(
                    format!("kinds[{i}]"),
                    k,
                    format!("must index the {} species names", names.len()),
                )
            })?;
            species.push(ELEMENTS[k as usize].to_string());
            kind_names.push(name.as_ref().to_string());
        }
        self.species = species;
        self.kind_names = Some(kind_names);
        Ok(self)
    }

    /// Sets the simulation cell: rows are the cell vectors a, b, c.
    pub fn lattice(&mut self, cell: [[f64; 3]; 3]) -> Result<&mut Self> {
        for (r, row) in cell.iter().enumerate() {
            for (c, &v) in row.iter().enumerate() {
                finite(&format!("lattice[{r}][{c}]"), v)?;
            }
        }
        self.lattice = Some(cell);
        Ok(self)
    }

    /// A 2D box `lx` x `ly` (cell vectors `(lx,0,0)`, `(0,ly,0)`, `(0,0,1)`), periodic in x
    /// and y (`pbc="T T F"`; override with [`pbc`](Self::pbc)).
    pub fn box_2d(&mut self, lx: f64, ly: f64) -> Result<&mut Self> {
        for (name, v) in [("lx", lx), ("ly", ly)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(
                    name,
                    v,
                    "box lengths must be finite and > 0",
                ));
            }
        }
        self.lattice([[lx, 0.0, 0.0], [0.0, ly, 0.0], [0.0, 0.0, 1.0]])?;
        self.pbc = Some([true, true, false]);
        Ok(self)
    }

    /// Sets the periodic boundary flags written as `pbc="T T F"`.
    pub fn pbc(&mut self, periodic: [bool; 3]) -> &mut Self {
        self.pbc = Some(periodic);
        self
    }

    /// Sets the frame's time (`Time=` in the comment line).
    pub fn time(&mut self, t: f64) -> Result<&mut Self> {
        finite("time", t)?;
        self.time = Some(t);
        Ok(self)
    }

    /// Adds a `key=value` number to the comment line (e.g. `step`, `energy`).
    ///
    /// Errors: a key that is not a name (letters, digits, `_`), one the comment line already
    /// has, one of the keys this type writes itself (`Lattice`, `Properties`, `Time`, `pbc`,
    /// in any case: set them with [`lattice`](Self::lattice), [`time`](Self::time),
    /// [`pbc`](Self::pbc)), or a non-finite value.
    pub fn info(&mut self, key: &str, value: f64) -> Result<&mut Self> {
        check_name(key)?;
        if RESERVED_KEYS.iter().any(|r| r.eq_ignore_ascii_case(key)) {
            return Err(Error::invalid(
                "info key",
                key,
                "is written by XyzFrame itself; use lattice, box_2d, time or pbc instead",
            ));
        }
        if self.info.iter().any(|(k, _)| k == key) {
            return Err(Error::invalid(
                "info key",
                key,
                "is already on this frame's comment line; use each key once",
            ));
        }
        finite(key, value)?;
        self.info.push((key.into(), numfmt::exact(value)));
        Ok(self)
    }

    /// Adds the particle radii as OVITO's standard `Radius` column (the drawn size).
    pub fn radii<T: Copy + Into<f64>>(&mut self, radii: &[T]) -> Result<&mut Self> {
        self.add_column("Radius", radii, 1)
    }

    /// Adds the velocities, `components` (2 or 3) interleaved values per particle, as the
    /// `velo` column (OVITO's `Velocity`; see the [module docs](self)).
    pub fn velocities<T: Copy + Into<f64>>(
        &mut self,
        velocities: &[T],
        components: usize,
    ) -> Result<&mut Self> {
        self.add_vector("velo", velocities, components)
    }

    /// Adds a real per-particle column (`name:R:1`). The names `species`, `pos` and `kind`
    /// are the writer's own.
    pub fn add_scalar<T: Copy + Into<f64>>(&mut self, name: &str, data: &[T]) -> Result<&mut Self> {
        self.add_column(name, data, 1)
    }

    /// Adds a vector column with `components` (2 or 3) interleaved values per particle;
    /// 2 components are padded with `0` (`name:R:3`).
    pub fn add_vector<T: Copy + Into<f64>>(
        &mut self,
        name: &str,
        data: &[T],
        components: usize,
    ) -> Result<&mut Self> {
        if components != 2 && components != 3 {
            return Err(Error::invalid(
                format!("{name} components"),
                components,
                "vectors have 2 or 3 components; use add_scalar for 1",
            ));
        }
        self.add_column(name, data, components)
    }

    fn add_column<T: Copy + Into<f64>>(
        &mut self,
        name: &str,
        data: &[T],
        components: usize,
    ) -> Result<&mut Self> {
        check_name(name)?;
        if RESERVED_COLUMNS.contains(&name) || self.columns.iter().any(|c| c.name == name) {
            return Err(Error::invalid(
                "property name",
                name,
                "already used in this frame; pick a unique name",
            ));
        }
        let n = self.len();
        if data.len() != n * components {
            return Err(Error::invalid(
                format!("{name}.len()"),
                data.len(),
                format!("expected {components} value(s) per particle ({n} particles)"),
            ));
        }
        let out_comp = if components == 1 { 1 } else { 3 };
        let mut out = Vec::with_capacity(n * out_comp);
        for (i, chunk) in data.chunks_exact(components).enumerate() {
            for &v in chunk {
                let v: f64 = v.into();
                finite(&format!("{name}[{i}]"), v)?;
                out.push(v);
            }
            if components == 2 {
                out.push(0.0);
            }
        }
        self.columns.push(Column {
            name: name.into(),
            components: out_comp,
            data: out,
        });
        Ok(self)
    }

    /// Appends this frame's text to `out`.
    pub fn write_to(&self, out: &mut String) {
        let n = self.len();
        let _ = writeln!(out, "{n}");
        let mut comment = String::new();
        if let Some(l) = &self.lattice {
            let vals: Vec<String> = l.iter().flatten().map(|v| numfmt::exact(*v)).collect();
            let _ = write!(comment, "Lattice=\"{}\" ", vals.join(" "));
        }
        comment.push_str("Properties=species:S:1:pos:R:3");
        if self.kind_names.is_some() {
            comment.push_str(":kind:S:1");
        }
        for c in &self.columns {
            let _ = write!(comment, ":{}:R:{}", c.name, c.components);
        }
        if let Some(t) = self.time {
            let _ = write!(comment, " Time={}", numfmt::exact(t));
        }
        for (k, v) in &self.info {
            let _ = write!(comment, " {k}={v}");
        }
        if let Some(p) = self.pbc {
            let f = |b: bool| if b { "T" } else { "F" };
            let _ = write!(comment, " pbc=\"{} {} {}\"", f(p[0]), f(p[1]), f(p[2]));
        }
        out.push_str(&comment);
        out.push('\n');
        for i in 0..n {
            out.push_str(&self.species[i]);
            for v in &self.positions[3 * i..3 * i + 3] {
                out.push(' ');
                out.push_str(&numfmt::exact(*v));
            }
            if let Some(names) = &self.kind_names {
                out.push(' ');
                out.push_str(&names[i]);
            }
            for c in &self.columns {
                for v in &c.data[c.components * i..c.components * (i + 1)] {
                    out.push(' ');
                    out.push_str(&numfmt::exact(*v));
                }
            }
            out.push('\n');
        }
    }
}

/// Writes all `frames` to `path` in one atomic write.
pub fn write_xyz(path: impl AsRef<Path>, frames: &[XyzFrame]) -> Result<()> {
    let mut text = String::new();
    for f in frames {
        f.write_to(&mut text);
    }
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

/// Appends frames to a trajectory in a temporary file; [`finish`](Self::finish) renames it
/// into place. Dropping without finishing leaves any previous file untouched.
#[derive(Debug)]
pub struct XyzWriter {
    file: AtomicFile,
    frames: usize,
    buf: String,
}

impl XyzWriter {
    /// Starts a trajectory at `path`.
    pub fn create(path: impl AsRef<Path>) -> Result<Self> {
        Ok(Self {
            file: AtomicFile::create(path)?,
            frames: 0,
            buf: String::new(),
        })
    }

    /// Number of frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Appends a frame.
    pub fn push(&mut self, frame: &XyzFrame) -> Result<()> {
        self.buf.clear();
        frame.write_to(&mut self.buf);
        self.file
            .write_all(self.buf.as_bytes())
            .map_err(|e| io_error(self.file.path(), &e))?;
        self.frames += 1;
        Ok(())
    }

    /// Flushes, syncs and renames the trajectory into place.
    pub fn finish(self) -> Result<()> {
        self.file.commit()
    }
}

fn finite(name: &str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::invalid(
            name,
            v,
            "extended XYZ readers cannot parse non-finite values; check the simulation",
        ))
    }
}

fn check_word(name: &str, s: &str) -> Result<()> {
    if s.is_empty()
        || s.chars()
            .any(|c| c.is_whitespace() || c.is_control() || c == '"' || c == '\'')
    {
        return Err(Error::invalid(
            name,
            format!("{s:?}"),
            "must be non-empty without whitespace, control characters or quotes",
        ));
    }
    Ok(())
}

fn check_element(name: &str, s: &str) -> Result<()> {
    if s == "X" || ELEMENTS.contains(&s) {
        return Ok(());
    }
    Err(Error::invalid(
        name,
        format!("{s:?}"),
        "is not an element symbol (H, He, ..., Og, or X), which ASE requires in the species \
         column; use XyzFrame::kinds to map species that are not elements",
    ))
}

fn check_name(name: &str) -> Result<()> {
    let ok = !name.is_empty()
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !name.starts_with(|c: char| c.is_ascii_digit());
    if !ok {
        return Err(Error::invalid(
            "property name",
            format!("{name:?}"),
            "use letters, digits and '_' only, not starting with a digit",
        ));
    }
    Ok(())
}
