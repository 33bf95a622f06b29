//! CSV time series: a header of column names, then rows of numbers.
//!
//! Values are written in shortest round-trip form ([`numfmt::exact`]), so they parse back
//! bit for bit; NaN and infinities are written as `NaN`, `inf`, `-inf`. Column names
//! containing commas, quotes or line breaks are quoted.
//!
//! ```
//! use simkit_output::csv::CsvWriter;
//! # fn main() -> simkit_backend::Result<()> {
//! let path = std::env::temp_dir().join("simkit-doc-csv").join("energy.csv");
//! let mut csv = CsvWriter::create(&path, &["t", "kinetic", "potential"])?;
//! for step in 0..10 {
//!     let t = step as f64 * 0.01;
//!     csv.row(&[t, 0.5 * t, 1.0 - 0.5 * t])?;
//! }
//! csv.finish()?; // the file appears here, atomically
//! # Ok(())
//! # }
//! ```

use std::io::Write;
use std::path::Path;

use crate::atomic::{AtomicFile, io_error, write_atomic};
use crate::numfmt;
use simkit_backend::{Error, Result};

/// Streams rows to a temporary file; [`finish`](Self::finish) renames it into place.
/// Dropping the writer without finishing leaves any previous file untouched.
#[derive(Debug)]
pub struct CsvWriter {
    file: AtomicFile,
    columns: usize,
    rows: usize,
    line: String,
}

impl CsvWriter {
    /// Starts a CSV file at `path` with the given column names (at least one).
    pub fn create<S: AsRef<str>>(path: impl AsRef<Path>, columns: &[S]) -> Result<Self> {
        let header = header_line(columns)?;
        let mut file = AtomicFile::create(path)?;
        file.write_all(header.as_bytes())
            .map_err(|e| io_error(file.path(), &e))?;
        Ok(Self {
            file,
            columns: columns.len(),
            rows: 0,
            line: String::new(),
        })
    }

    /// Number of columns.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// Number of rows written so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Appends one row; errors when `values.len()` differs from the number of columns.
    pub fn row(&mut self, values: &[f64]) -> Result<()> {
        check_width(self.rows, values.len(), self.columns)?;
        self.line.clear();
        format_row(&mut self.line, values);
        self.file
            .write_all(self.line.as_bytes())
            .map_err(|e| io_error(self.file.path(), &e))?;
        self.rows += 1;
        Ok(())
    }

    /// Flushes, syncs and renames the file into place.
    pub fn finish(self) -> Result<()> {
        self.file.commit()
    }
}

/// Writes a whole CSV file at once (atomically). Every row must have `columns.len()` values.
pub fn write_csv<S: AsRef<str>, R: AsRef<[f64]>>(
    path: impl AsRef<Path>,
    columns: &[S],
    rows: &[R],
) -> Result<()> {
    let mut text = header_line(columns)?;
    for (i, r) in rows.iter().enumerate() {
        check_width(i, r.as_ref().len(), columns.len())?;
        format_row(&mut text, r.as_ref());
    }
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

fn check_width(row: usize, got: usize, want: usize) -> Result<()> {
    if got != want {
        return Err(Error::invalid(
            format!("row {row} width"),
            got,
            format!("expected {want} values, one per column"),
        ));
    }
    Ok(())
}

fn header_line<S: AsRef<str>>(columns: &[S]) -> Result<String> {
    if columns.is_empty() {
        return Err(Error::invalid(
            "columns",
            "[]",
            "a CSV file needs at least one column name",
        ));
    }
    let mut out = String::new();
    for (i, c) in columns.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        let c = c.as_ref();
        if c.contains([',', '"', '\n', '\r']) {
            out.push('"');
            out.push_str(&c.replace('"', "\"\""));
            out.push('"');
        } else {
            out.push_str(c);
        }
    }
    out.push('\n');
    Ok(out)
}

fn format_row(out: &mut String, values: &[f64]) {
    for (i, v) in values.iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        out.push_str(&numfmt::exact(*v));
    }
    out.push('\n');
}
