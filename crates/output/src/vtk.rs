//! VTK XML files that ParaView, VTK and OVITO open: `.vti` image data (2D/3D grids with
//! scalar and vector point fields), `.vtp` poly data (particles: one vertex per particle, with
//! named point arrays) and `.pvd` collections for time series.
//!
//! Files follow the VTK XML format (`VTKFile` version 0.1, `byte_order="LittleEndian"`,
//! `header_type="UInt64"`). Real arrays are `Float64` and integer arrays
//! ([`Particles::add_ints`]) `Int64`; by default they are stored `format="binary"` (base64 of
//! a `UInt64` byte count, as the root element declares, followed by the little-endian values),
//! which keeps NaN exact and files small; [`Encoding::Ascii`] writes readable text instead,
//! each value in the shortest form that parses back to the same `f64` ([`numfmt::exact`]),
//! and then rejects non-finite values, which text readers cannot parse. Either way a value
//! read back equals the value written bit for bit. Vectors with 2 components are padded to 3
//! with zeros, as ParaView's glyph and stream filters expect.
//!
//! Viewers pick particle properties by array name. OVITO (checked with 3.17) maps `radius`
//! to its `Radius` property (the drawn size), `id` to `Particle Identifier` and `Velocity`
//! (its standard name; `velocity` is not mapped) to `Velocity`; other arrays, such as an
//! integer `species`, become user properties to colour by. ParaView takes any name. So name
//! the drawn size `radius` and keep other quantities under names that say what they are.
//!
//! ```
//! use simkit_output::vtk::Particles;
//! # fn main() -> simkit_backend::Result<()> {
//! let xy = [[0.0, 0.0], [1.0, 0.5], [2.0, 1.0]];
//! let mut p = Particles::from_xy(&xy)?;
//! p.add_scalar("radius", &[0.5, 0.5, 0.25])?
//!     .add_ints("species", &[0u32, 1, 1])?
//!     .add_vector("Velocity", &[1.0, 0.0, 0.0, 1.0, -1.0, 0.0], 2)?;
//! let path = std::env::temp_dir().join("simkit-doc-vtk").join("particles_0000.vtp");
//! p.write(&path)?;
//! # Ok(())
//! # }
//! ```

use std::fmt::Write as _;
use std::path::Path;

use crate::atomic::write_atomic;
use crate::numfmt;
use simkit_backend::{Error, Result};

/// How array values are stored in the XML.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Encoding {
    /// `format="binary"`: base64, exact, compact (default).
    #[default]
    Binary,
    /// `format="ascii"`: human-readable; non-finite values are rejected.
    Ascii,
}

/// The values of one array: `Float64` or `Int64`.
#[derive(Debug, Clone, PartialEq)]
enum Values {
    F64(Vec<f64>),
    I64(Vec<i64>),
}

#[derive(Debug, Clone, PartialEq)]
struct Array {
    name: String,
    components: usize,
    data: Values,
}

/// Named point arrays shared by [`ImageData`] and [`Particles`].
#[derive(Debug, Clone, PartialEq, Default)]
struct PointArrays {
    scalars: Vec<Array>,
    vectors: Vec<Array>,
}

impl PointArrays {
    fn check_name(&self, name: &str) -> Result<()> {
        if name.trim().is_empty() {
            return Err(Error::invalid(
                "array name",
                format!("{name:?}"),
                "must not be empty",
            ));
        }
        if name.chars().any(char::is_control) {
            return Err(Error::invalid(
                "array name",
                format!("{name:?}"),
                "must not contain control characters (XML attributes cannot hold them)",
            ));
        }
        if self
            .scalars
            .iter()
            .chain(&self.vectors)
            .any(|a| a.name == name)
        {
            return Err(Error::invalid(
                "array name",
                name,
                "already used by another array of this file; pick a unique name",
            ));
        }
        Ok(())
    }

    /// Checks a new one-component array: a unique name and one value per point.
    fn check_scalar(&self, points: usize, name: &str, len: usize) -> Result<()> {
        self.check_name(name)?;
        if len != points {
            return Err(Error::invalid(
                format!("{name}.len()"),
                len,
                format!("expected one value per point ({points})"),
            ));
        }
        Ok(())
    }

    fn add_scalar<T: Copy + Into<f64>>(
        &mut self,
        points: usize,
        name: &str,
        data: &[T],
    ) -> Result<()> {
        self.check_scalar(points, name, data.len())?;
        self.push_scalar(name, Values::F64(data.iter().map(|&v| v.into()).collect()));
        Ok(())
    }

    fn add_ints<T: Copy + Into<i64>>(
        &mut self,
        points: usize,
        name: &str,
        data: &[T],
    ) -> Result<()> {
        self.check_scalar(points, name, data.len())?;
        self.push_scalar(name, Values::I64(data.iter().map(|&v| v.into()).collect()));
        Ok(())
    }

    /// Appends a one-component array (its length already checked).
    fn push_scalar(&mut self, name: &str, data: Values) {
        self.scalars.push(Array {
            name: name.into(),
            components: 1,
            data,
        });
    }

    fn add_vector<T: Copy + Into<f64>>(
        &mut self,
        points: usize,
        name: &str,
        data: &[T],
        components: usize,
    ) -> Result<()> {
        self.check_name(name)?;
        if components != 2 && components != 3 {
            return Err(Error::invalid(
                format!("{name} components"),
                components,
                "vectors have 2 or 3 components; use add_scalar for 1",
            ));
        }
        let expected = points.checked_mul(components);
        if expected != Some(data.len()) {
            let expected =
                expected.map_or_else(|| "more than usize::MAX".into(), |e| e.to_string());
            return Err(Error::invalid(
                format!("{name}.len()"),
                data.len(),
                format!(
                    "expected {components} values per point ({points} points = {expected}), \
                     interleaved x, y[, z]"
                ),
            ));
        }
        self.vectors.push(Array {
            name: name.into(),
            components: 3,
            data: Values::F64(pad3(data, components)),
        });
        Ok(())
    }

    fn write_xml(&self, out: &mut String, enc: Encoding, indent: &str) -> Result<()> {
        let mut attrs = String::new();
        if let Some(a) = self.scalars.first() {
            let _ = write!(attrs, " Scalars=\"{}\"", escape(&a.name));
        }
        if let Some(a) = self.vectors.first() {
            let _ = write!(attrs, " Vectors=\"{}\"", escape(&a.name));
        }
        let _ = writeln!(out, "{indent}<PointData{attrs}>");
        for a in self.scalars.iter().chain(&self.vectors) {
            let kind = match a.data {
                Values::F64(_) => "Float64",
                Values::I64(_) => "Int64",
            };
            let _ = write!(
                out,
                "{indent}  <DataArray type=\"{kind}\" Name=\"{}\" NumberOfComponents=\"{}\" ",
                escape(&a.name),
                a.components
            );
            match &a.data {
                Values::F64(v) => write_f64s(out, &a.name, v, enc)?,
                Values::I64(v) => write_raw(out, v, enc),
            }
        }
        let _ = writeln!(out, "{indent}</PointData>");
        Ok(())
    }
}

/// Checks that `len` interleaved values hold whole particles of `dim` (2 or 3) coordinates.
pub(crate) fn check_interleaved(len: usize, dim: usize) -> Result<()> {
    if dim != 2 && dim != 3 {
        return Err(Error::invalid(
            "dim",
            dim,
            "positions have 2 or 3 coordinates per particle",
        ));
    }
    if !len.is_multiple_of(dim) {
        return Err(Error::invalid(
            "positions.len()",
            len,
            format!("must be a multiple of dim = {dim} (interleaved x, y[, z])"),
        ));
    }
    Ok(())
}

fn pad3<T: Copy + Into<f64>>(data: &[T], components: usize) -> Vec<f64> {
    if components == 3 {
        return data.iter().map(|&v| v.into()).collect();
    }
    let mut out = Vec::with_capacity(data.len() / 2 * 3);
    for c in data.chunks_exact(2) {
        out.extend_from_slice(&[c[0].into(), c[1].into(), 0.0]);
    }
    out
}

/// A regular 2D or 3D grid (`.vti`) with point data. Values are indexed
/// `i + nx * (j + ny * k)` (x fastest), matching row-major 2D fields with rows along x.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageData {
    dims: [usize; 3],
    origin: [f64; 3],
    spacing: [f64; 3],
    arrays: PointArrays,
    encoding: Encoding,
}

impl ImageData {
    /// A grid of `dims = [nx, ny, nz]` points (`nz = 1` for 2D) at `origin` with `spacing`.
    ///
    /// Errors on a zero dimension, a non-finite origin or a spacing that is not finite and
    /// positive.
    pub fn new(dims: [usize; 3], origin: [f64; 3], spacing: [f64; 3]) -> Result<Self> {
        if dims.contains(&0) {
            return Err(Error::invalid(
                "dims",
                format!("{dims:?}"),
                "every dimension must be >= 1 (use nz = 1 for a 2D grid)",
            ));
        }
        dims.iter()
            .try_fold(1usize, |acc, &d| acc.checked_mul(d))
            .ok_or_else(|| Error::invalid("dims", format!("{dims:?}"), "too many points"))?;
        for (axis, (&o, &s)) in ["x", "y", "z"].iter().zip(origin.iter().zip(&spacing)) {
            if !o.is_finite() {
                return Err(Error::invalid(
                    format!("origin.{axis}"),
                    o,
                    "must be finite",
                ));
            }
            if !(s.is_finite() && s > 0.0) {
                return Err(Error::invalid(
                    format!("spacing.{axis}"),
                    s,
                    "must be finite and > 0 (use 1 for the unused axis of a 2D grid)",
                ));
            }
        }
        Ok(Self {
            dims,
            origin,
            spacing,
            arrays: PointArrays::default(),
            encoding: Encoding::default(),
        })
    }

    /// A 2D grid of `nx` x `ny` points (stored with `nz = 1`, z spacing 1).
    pub fn new_2d(nx: usize, ny: usize, origin: [f64; 2], spacing: [f64; 2]) -> Result<Self> {
        Self::new(
            [nx, ny, 1],
            [origin[0], origin[1], 0.0],
            [spacing[0], spacing[1], 1.0],
        )
    }

    /// Selects how arrays are stored (default [`Encoding::Binary`]).
    pub fn encoding(mut self, encoding: Encoding) -> Self {
        self.encoding = encoding;
        self
    }

    /// Number of grid points.
    pub fn points(&self) -> usize {
        self.dims.iter().product()
    }

    /// Adds a scalar point field (one value per point). Names must be unique.
    pub fn add_scalar<T: Copy + Into<f64>>(&mut self, name: &str, data: &[T]) -> Result<&mut Self> {
        self.arrays.add_scalar(self.points(), name, data)?;
        Ok(self)
    }

    /// Adds a vector point field with `components` (2 or 3) interleaved values per point.
    pub fn add_vector<T: Copy + Into<f64>>(
        &mut self,
        name: &str,
        data: &[T],
        components: usize,
    ) -> Result<&mut Self> {
        self.arrays
            .add_vector(self.points(), name, data, components)?;
        Ok(self)
    }

    /// The XML text of the file.
    pub fn to_xml(&self) -> Result<String> {
        let [nx, ny, nz] = self.dims;
        let extent = format!("0 {} 0 {} 0 {}", nx - 1, ny - 1, nz - 1);
        let mut out = String::new();
        header(&mut out, "ImageData");
        let _ = writeln!(
            out,
            "  <ImageData WholeExtent=\"{extent}\" Origin=\"{}\" Spacing=\"{}\">",
            join3(&self.origin),
            join3(&self.spacing)
        );
        let _ = writeln!(out, "    <Piece Extent=\"{extent}\">");
        self.arrays.write_xml(&mut out, self.encoding, "      ")?;
        let _ = writeln!(out, "      <CellData>\n      </CellData>");
        let _ = writeln!(out, "    </Piece>\n  </ImageData>\n</VTKFile>");
        Ok(out)
    }

    /// Writes the `.vti` file atomically.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        let xml = self.to_xml()?;
        write_atomic(path, |w| w.write_all(xml.as_bytes()))
    }
}

/// Particles as VTK poly data (`.vtp`): one vertex per particle (`<Verts>`), with named
/// scalar, integer and vector point arrays (radius, species, id, velocity, ...). This is
/// the file kind OVITO reads particles from, and ParaView draws it with its point
/// Gaussian or glyph representations.
#[derive(Debug, Clone, PartialEq)]
pub struct Particles {
    positions: Vec<f64>,
    arrays: PointArrays,
    encoding: Encoding,
}

impl Particles {
    /// Particles from interleaved coordinates with `dim` (2 or 3) values per particle;
    /// 2D positions get `z = 0`. Works with `bytemuck::cast_slice` of `Vec2`/`Vec3` arrays.
    pub fn new<T: Copy + Into<f64>>(positions: &[T], dim: usize) -> Result<Self> {
        check_interleaved(positions.len(), dim)?;
        Ok(Self {
            positions: pad3(positions, dim),
            arrays: PointArrays::default(),
            encoding: Encoding::default(),
        })
    }

    /// Particles from 2D points (`z = 0`).
    pub fn from_xy(points: &[[f64; 2]]) -> Result<Self> {
        Self::new(points.as_flattened(), 2)
    }

    /// Particles from 3D points.
    pub fn from_xyz(points: &[[f64; 3]]) -> Result<Self> {
        Self::new(points.as_flattened(), 3)
    }

    /// Selects how arrays are stored (default [`Encoding::Binary`]).
    pub fn encoding(mut self, encoding: Encoding) -> Self {
        self.encoding = encoding;
        self
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len() / 3
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Adds a scalar point array (one value per particle). Names must be unique.
    pub fn add_scalar<T: Copy + Into<f64>>(&mut self, name: &str, data: &[T]) -> Result<&mut Self> {
        self.arrays.add_scalar(self.len(), name, data)?;
        Ok(self)
    }

    /// Adds an integer point array (`Int64`, one value per particle), for species indices
    /// and identifiers. Names must be unique among all arrays of the file.
    pub fn add_ints<T: Copy + Into<i64>>(&mut self, name: &str, data: &[T]) -> Result<&mut Self> {
        self.arrays.add_ints(self.len(), name, data)?;
        Ok(self)
    }

    /// Adds a vector point array with `components` (2 or 3) interleaved values per particle.
    pub fn add_vector<T: Copy + Into<f64>>(
        &mut self,
        name: &str,
        data: &[T],
        components: usize,
    ) -> Result<&mut Self> {
        self.arrays.add_vector(self.len(), name, data, components)?;
        Ok(self)
    }

    /// The XML text of the file.
    pub fn to_xml(&self) -> Result<String> {
        let n = self.len();
        let enc = self.encoding;
        let mut out = String::new();
        header(&mut out, "PolyData");
        let _ = writeln!(out, "  <PolyData>");
        let _ = writeln!(
            out,
            "    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{n}\" NumberOfLines=\"0\" \
             NumberOfStrips=\"0\" NumberOfPolys=\"0\">"
        );
        self.arrays.write_xml(&mut out, enc, "      ")?;
        let _ = writeln!(out, "      <CellData>\n      </CellData>");
        let _ = writeln!(out, "      <Points>");
        out.push_str(
            "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" ",
        );
        write_f64s(&mut out, "positions", &self.positions, enc)?;
        let _ = writeln!(out, "      </Points>");
        let _ = writeln!(out, "      <Verts>");
        let ids: Vec<i64> = (0..n as i64).collect();
        let offsets: Vec<i64> = (1..=n as i64).collect();
        out.push_str("        <DataArray type=\"Int64\" Name=\"connectivity\" ");
        write_raw(&mut out, &ids, enc);
        out.push_str("        <DataArray type=\"Int64\" Name=\"offsets\" ");
        write_raw(&mut out, &offsets, enc);
        let _ = writeln!(out, "      </Verts>");
        let _ = writeln!(out, "    </Piece>\n  </PolyData>\n</VTKFile>");
        Ok(out)
    }

    /// Writes the `.vtp` file atomically.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        let xml = self.to_xml()?;
        write_atomic(path, |w| w.write_all(xml.as_bytes()))
    }
}

/// Writes a ParaView collection (`.pvd`) listing `(time, file)` pairs, so that a series of
/// `.vti`/`.vtp` files opens as one time-dependent dataset. File paths are written as given
/// (relative paths are relative to the `.pvd` file's directory).
///
/// Errors: a non-finite time, a file path with control characters, or an I/O failure.
pub fn write_pvd<P: AsRef<Path>>(path: impl AsRef<Path>, entries: &[(f64, P)]) -> Result<()> {
    let mut out = String::new();
    header(&mut out, "Collection");
    out.push_str("  <Collection>\n");
    for (i, (t, file)) in entries.iter().enumerate() {
        if !t.is_finite() {
            return Err(Error::invalid(
                format!("entries[{i}].time"),
                t,
                "must be finite",
            ));
        }
        let file = file.as_ref().to_string_lossy().replace('\\', "/");
        if file.chars().any(char::is_control) {
            return Err(Error::invalid(
                format!("entries[{i}].file"),
                format!("{file:?}"),
                "must not contain control characters (XML attributes cannot hold them)",
            ));
        }
        let _ = writeln!(
            out,
            "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\"/>",
            numfmt::exact(*t),
            escape(&file)
        );
    }
    out.push_str("  </Collection>\n</VTKFile>\n");
    write_atomic(path, |w| w.write_all(out.as_bytes()))
}

fn header(out: &mut String, kind: &str) {
    let _ = writeln!(out, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        out,
        "<VTKFile type=\"{kind}\" version=\"0.1\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">"
    );
}

fn join3(v: &[f64; 3]) -> String {
    format!(
        "{} {} {}",
        numfmt::exact(v[0]),
        numfmt::exact(v[1]),
        numfmt::exact(v[2])
    )
}

/// Writes the rest of a `<DataArray ...` tag (format attribute, content, closing tag).
fn write_f64s(out: &mut String, name: &str, data: &[f64], enc: Encoding) -> Result<()> {
    if enc == Encoding::Ascii
        && let Some(i) = data.iter().position(|v| !v.is_finite())
    {
        return Err(Error::invalid(
            format!("{name}[{i}]"),
            data[i],
            "ASCII VTK cannot store non-finite values; use Encoding::Binary or clean the data",
        ));
    }
    write_raw(out, data, enc);
    Ok(())
}

/// A value type of a VTK `DataArray`: its little-endian bytes (binary) and its text (ASCII).
trait VtkValue: Copy {
    /// Appends the little-endian bytes.
    fn push_le(self, raw: &mut Vec<u8>);
    /// Appends the text form, which parses back to the same value.
    fn push_text(self, out: &mut String);
}

impl VtkValue for f64 {
    fn push_le(self, raw: &mut Vec<u8>) {
        raw.extend_from_slice(&self.to_le_bytes());
    }
    /// Shortest round-trip form ([`numfmt::exact`]): `1e-300`, not 300 zeros.
    fn push_text(self, out: &mut String) {
        out.push_str(&numfmt::exact(self));
    }
}

impl VtkValue for i64 {
    fn push_le(self, raw: &mut Vec<u8>) {
        raw.extend_from_slice(&self.to_le_bytes());
    }
    fn push_text(self, out: &mut String) {
        let _ = write!(out, "{self}");
    }
}

/// Writes the rest of a `<DataArray ...` tag for values that are always finite.
/// Binary data is the `UInt64` byte count (the root's `header_type`) and the values.
fn write_raw<T: VtkValue>(out: &mut String, data: &[T], enc: Encoding) {
    match enc {
        Encoding::Ascii => {
            out.push_str("format=\"ascii\">\n");
            for chunk in data.chunks(9) {
                out.push_str("         ");
                for &v in chunk {
                    out.push(' ');
                    v.push_text(out);
                }
                out.push('\n');
            }
        }
        Encoding::Binary => {
            out.push_str("format=\"binary\">\n          ");
            let bytes = std::mem::size_of_val(data);
            let mut raw = Vec::with_capacity(8 + bytes);
            raw.extend_from_slice(&(bytes as u64).to_le_bytes());
            for &v in data {
                v.push_le(&mut raw);
            }
            base64_into(out, &raw);
            out.push('\n');
        }
    }
    out.push_str("        </DataArray>\n");
}

fn base64_into(out: &mut String, data: &[u8]) {
    const TABLE: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    out.reserve(data.len().div_ceil(3) * 4);
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        out.push(TABLE[(n >> 18) as usize & 63] as char);
        out.push(TABLE[(n >> 12) as usize & 63] as char);
        out.push(if chunk.len() > 1 {
            TABLE[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        out.push(if chunk.len() > 2 {
            TABLE[n as usize & 63] as char
        } else {
            '='
        });
    }
}

/// Escapes text for an XML attribute value.
pub(crate) fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_known_values() {
        for (input, want) in [
            (&b""[..], ""),
            (b"f", "Zg=="),
            (b"fo", "Zm8="),
            (b"foo", "Zm9v"),
            (b"foobar", "Zm9vYmFy"),
        ] {
            let mut s = String::new();
            base64_into(&mut s, input);
            assert_eq!(s, want);
        }
    }

    #[test]
    fn validation() {
        assert!(ImageData::new([0, 1, 1], [0.0; 3], [1.0; 3]).is_err());
        assert!(ImageData::new_2d(2, 2, [0.0; 2], [1.0, 0.0]).is_err());
        let mut g = ImageData::new_2d(2, 2, [0.0; 2], [1.0; 2]).unwrap();
        assert!(g.add_scalar("a", &[1.0; 3]).is_err());
        g.add_scalar("a", &[1.0; 4]).unwrap();
        assert!(g.add_scalar("a", &[1.0; 4]).is_err());
        assert!(g.add_vector("v", &[1.0; 4], 1).is_err());
        assert!(Particles::new(&[1.0; 5], 2).is_err());
        let mut p = Particles::new(&[f64::NAN, 0.0], 2)
            .unwrap()
            .encoding(Encoding::Ascii);
        assert!(p.to_xml().is_err());
        p = p.encoding(Encoding::Binary);
        assert!(p.to_xml().is_ok());
        assert_eq!(escape("a<\"b\">&"), "a&lt;&quot;b&quot;&gt;&amp;");
    }
}
