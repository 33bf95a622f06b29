//! Robustness: every public constructor, setter, builder and writer of this crate driven with
//! arbitrary values (NaN, ±inf, ±0, negative, huge, subnormal, sizes that do not match the
//! data, empty inputs, arbitrary strings, coordinates anywhere in `i64`, paths that cannot be
//! written). Every call must give `Ok` with a valid result (images of the promised size,
//! finite ranges, files that parse back to the values written) or an `Err` whose message
//! names the bad value; a panic, an abort or a hang fails the test. Files are checked to be
//! written atomically: after an error the previous file is intact, and no temporary file is
//! left either way.
//!
//! Reproducible: every property runs a fixed number of cases drawn from a fixed seed
//! ([`SEED`], ChaCha), so a failure shows on every run and proptest prints the minimal input;
//! no regression files are written. Change `SEED` to explore other inputs.
//!
//! Sized to run in seconds: grids of at most 6 x 6 cells, plots of at most 200 x 120
//! pixels; huge sizes appear only where they must be refused.

use approx::abs_diff_eq;
use std::path::{Path, PathBuf};

use image::{AnimationDecoder, Rgb, RgbImage};
use proptest::prelude::*;
use simkit_backend::Error;
use simkit_backend::testing::robust::{self, awkward_f64, mostly};
use simkit_output::colormap::{Colormap, NAN_COLOR, luminance};
use simkit_output::csv::{CsvWriter, write_csv};
use simkit_output::gif::{GifWriter, MAX_DELAY_MS, write_gif};
use simkit_output::heatmap::{HeatmapOptions, MAX_SIDE, render_heatmap, write_heatmap};
use simkit_output::plot::{Plot, Scale, Series, Style};
use simkit_output::vector_field::{VectorFieldOptions, render_vector_field, write_vector_field};
use simkit_output::vtk::{Encoding, ImageData, Particles, write_pvd};
use simkit_output::xyz::{ELEMENTS, XyzFrame, XyzWriter, write_xyz};
use simkit_output::{numfmt, png};

/// The seed of every property in this file.
const SEED: u64 = 0x5eed_0070_7075;

/// Grid sizes: small ones, and the values around the limits of `u32` and `usize`.
fn size() -> impl Strategy<Value = usize> {
    prop_oneof![
        8 => 1..7usize,
        1 => Just(0),
        1 => prop::sample::select(vec![
            1 << 16,
            u32::MAX as usize,
            1 << 33,
            usize::MAX / 2,
            usize::MAX,
        ]),
    ]
}

/// Scale factors: small ones, and ones that make any image too large.
fn factor() -> impl Strategy<Value = u32> {
    prop_oneof![
        8 => 1..4u32,
        1 => Just(0),
        1 => prop::sample::select(vec![1 << 15, 1 << 20, u32::MAX]),
    ]
}

/// Text: names, the words the formats reserve, quotes, control characters, any Unicode.
fn text() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => "[a-zA-Z_][a-zA-Z0-9_]{0,8}",
        2 => prop::sample::select(vec![
            "", " ", "a b", "\"", "'", "<&>", "x\ny", "tab\t", "nul\0", "species", "pos",
            "Time", "time", "pbc", "Lattice", "Properties", "1abc", "é", "∞", "a,b", "a\"b",
        ])
        .prop_map(String::from),
        1 => any::<String>(),
    ]
}

/// The error message names one of `names`.
fn assert_names(e: &Error, names: &[&str]) {
    let s = e.to_string();
    assert!(
        names.iter().any(|n| s.contains(n)),
        "the error names none of {names:?}: {s}"
    );
}

/// Values of `len` (or, sometimes, of another length).
fn values(len: impl Strategy<Value = usize>) -> impl Strategy<Value = Vec<f64>> {
    len.prop_flat_map(|n| prop::collection::vec(mostly(-10.0..10.0), n))
}

fn heatmap_options() -> impl Strategy<Value = HeatmapOptions> {
    (
        prop::sample::select(vec![Colormap::Viridis, Colormap::Diverging, Colormap::Gray]),
        prop::option::weighted(
            0.3,
            prop_oneof![(-5.0..0.0f64, 0.0..5.0f64), (awkward_f64(), awkward_f64())],
        ),
        any::<bool>(),
        any::<bool>(),
        factor(),
        any::<bool>(),
        prop::option::weighted(0.4, text()),
        prop::option::weighted(0.3, text()),
        prop::option::weighted(0.2, (awkward_f64(), awkward_f64())),
    )
        .prop_map(|(cmap, range, sym, top, up, bar, title, quantity, x)| {
            let mut o = HeatmapOptions::new()
                .colormap(cmap)
                .symmetric(sym)
                .row0_at_top(top)
                .upscale(up)
                .colorbar(bar);
            if let Some((a, b)) = range {
                o = o.range(a, b);
            }
            if let Some(t) = title {
                o = o.title(t);
            }
            if let Some(q) = quantity {
                o = o.quantity(q);
            }
            if let Some((x0, x1)) = x {
                o = o.extent(x0, x1, 0.0, 1.0);
            }
            o
        })
}

/// A rendered field's range is finite and holds every finite value (automatic range); the
/// image holds the field (at least `upscale` pixels per cell) and the colour of every cell.
fn check_field(
    img: &RgbImage,
    range: (f64, f64),
    values: &[f64],
    (w, h): (usize, usize),
    o: &HeatmapOptions,
) {
    let (lo, hi) = range;
    assert!(
        lo.is_finite() && hi.is_finite() && lo < hi,
        "range {range:?}"
    );
    if o.range.is_none() {
        for &v in values.iter().filter(|v| v.is_finite()) {
            assert!(lo <= v && v <= hi, "{v} outside the range {range:?}");
        }
    }
    assert!(img.width() as usize <= MAX_SIDE && img.height() as usize <= MAX_SIDE);
    let s = o.upscale as usize;
    assert!(img.width() as usize >= w * s && img.height() as usize >= h * s);
    let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    for &v in values {
        let want = o.colormap.map_range(v, lo, hi);
        assert!(colours.contains(&want), "no pixel of the colour of {v}");
    }
}

proptest! {
    #![proptest_config(robust::config(SEED, 2000))]

    /// Heat maps of any size, data and options.
    #[test]
    fn heatmaps_render_or_refuse(
        (w, h) in (size(), size()),
        data in values(prop_oneof![4 => 0..40usize, 1 => 0..3usize]),
        fit in prop::bool::weighted(0.85),
        o in heatmap_options(),
    ) {
        // Usually data of the grid's size, so that the rendering itself is exercised.
        let data = match w.checked_mul(h) {
            Some(n) if fit && n <= 36 => {
                let mut d = data;
                d.resize(n, 0.5);
                d
            }
            _ => data,
        };
        match render_heatmap(&data, w, h, &o) {
            Ok((img, range)) => {
                prop_assert!(w >= 1 && h >= 1 && Some(data.len()) == w.checked_mul(h));
                prop_assert!(o.upscale >= 1);
                check_field(&img, range, &data, (w, h), &o);
            }
            Err(e) => assert_names(
                &e,
                &["grid size", "data", "upscale", "extent", "range"],
            ),
        }
    }

    /// Vector fields of any size, data and options.
    #[test]
    fn vector_fields_render_or_refuse(
        (w, h) in (size(), size()),
        vx in values(0..40usize),
        vy in values(0..40usize),
        fit in prop::bool::weighted(0.85),
        background in heatmap_options(),
        spacing in prop_oneof![4 => 0..8usize, 1 => size()],
        color in prop::option::of(any::<[u8; 3]>()),
    ) {
        let (vx, vy) = match w.checked_mul(h) {
            Some(n) if fit && n <= 36 => {
                let (mut a, mut b) = (vx, vy);
                a.resize(n, 1.0);
                b.resize(n, -1.0);
                (a, b)
            }
            _ => (vx, vy),
        };
        let mut o = VectorFieldOptions::new().background(background).arrow_spacing(spacing);
        if let Some(c) = color {
            o = o.arrow_color(c);
        }
        match render_vector_field(&vx, &vy, w, h, &o) {
            Ok((img, range)) => {
                let n = w.checked_mul(h);
                prop_assert!(Some(vx.len()) == n && Some(vy.len()) == n);
                prop_assert!(range.0.is_finite() && range.1.is_finite() && range.0 < range.1);
                prop_assert!(img.width() as usize <= MAX_SIDE && img.height() as usize <= MAX_SIDE);
            }
            Err(e) => assert_names(
                &e,
                &["grid size", "vx", "vy", "data", "upscale", "extent", "range",
                  "arrow_spacing"],
            ),
        }
    }
}

/// Plot data: mostly positive finite values (valid on log axes too), sometimes wild ones.
fn plot_values() -> impl Strategy<Value = Vec<f64>> {
    prop_oneof![
        5 => prop::collection::vec(0.01..100.0f64, 1..6),
        1 => values(0..6usize),
    ]
}

fn series() -> impl Strategy<Value = Series> {
    (
        text(),
        plot_values(),
        plot_values(),
        prop::bool::weighted(0.9),
        prop::sample::select(vec![Style::Line, Style::Points, Style::LinePoints]),
        prop::option::of(any::<[u8; 3]>()),
    )
        .prop_map(|(name, x, mut y, same, style, color)| {
            if same {
                y.resize(x.len(), 1.0);
            }
            let s = Series::line(name, &x, &y).style(style);
            match color {
                Some(c) => s.color(c),
                None => s,
            }
        })
}

proptest! {
    #![proptest_config(robust::config(SEED, 1500))]

    /// Plots of any size, scales, ranges, labels and series.
    #[test]
    fn plots_render_or_refuse(
        (title, xl, yl) in (text(), text(), text()),
        (xs, ys) in prop::sample::select(vec![
            (Scale::Linear, Scale::Linear),
            (Scale::Log10, Scale::Linear),
            (Scale::Linear, Scale::Log10),
            (Scale::Log10, Scale::Log10),
        ]),
        (xr, yr) in (
            prop::option::weighted(0.2, (awkward_f64(), awkward_f64())),
            prop::option::weighted(0.2, (awkward_f64(), awkward_f64())),
        ),
        (w, h) in prop_oneof![
            6 => (100..200u32, 80..120u32),
            1 => prop::sample::select(vec![
                (0, 0), (99, 80), (100, 79), (100, 80), (MAX_SIDE as u32 + 1, 100),
                (100, u32::MAX), (u32::MAX, u32::MAX),
            ]),
        ],
        legend in any::<bool>(),
        all in prop::collection::vec(series(), 0..4),
    ) {
        let mut p = Plot::new(title)
            .x_label(xl)
            .y_label(yl)
            .x_scale(xs)
            .y_scale(ys)
            .size(w, h)
            .legend(legend);
        if let Some((a, b)) = xr {
            p = p.x_range(a, b);
        }
        if let Some((a, b)) = yr {
            p = p.y_range(a, b);
        }
        for s in &all {
            p.push(s.clone());
        }
        // What the plot must refuse, whatever else it checks.
        let positive = |v: f64, s: Scale| v.is_finite() && (s == Scale::Linear || v > 0.0);
        let data_ok = !all.is_empty()
            && all.iter().all(|s| {
                !s.x.is_empty()
                    && s.x.len() == s.y.len()
                    && s.x.iter().all(|&v| positive(v, xs))
                    && s.y.iter().all(|&v| positive(v, ys))
            });
        match p.render() {
            Ok(img) => {
                prop_assert!(data_ok, "a plot of invalid data was drawn");
                prop_assert_eq!(img.dimensions(), (w, h));
            }
            Err(e) => assert_names(&e, &["plot series", "series ", "plot size", "range"]),
        }
    }
}

/// XML text of a VTK file: one document with `arrays` data arrays, nothing a parser cannot
/// read.
fn check_vtk(xml: &str, kind: &str, arrays: usize) {
    assert!(xml.starts_with("<?xml version=\"1.0\"?>\n"), "{xml}");
    assert!(xml.contains(&format!("<VTKFile type=\"{kind}\"")));
    assert_eq!(xml.matches("header_type=\"UInt64\"").count(), 1, "{xml}");
    assert!(xml.ends_with("</VTKFile>\n"));
    assert_eq!(xml.matches("<DataArray ").count(), arrays);
    assert_eq!(xml.matches("</DataArray>").count(), arrays);
    assert!(
        !xml.chars().any(|c| c.is_control() && c != '\n'),
        "control character in {xml:?}"
    );
}

proptest! {
    #![proptest_config(robust::config(SEED, 2000))]

    /// `.vti` grids and `.vtp` particles with any sizes, coordinates, array names and data.
    #[test]
    fn vtk_documents_or_refusals(
        dims in prop::array::uniform3(prop_oneof![6 => 0..4usize, 1 => size()]),
        origin in prop::array::uniform3(mostly(-5.0..5.0)),
        spacing in prop::array::uniform3(mostly(0.1..2.0)),
        positions in values(0..13usize),
        dim in prop_oneof![4 => 2..4usize, 1 => size()],
        arrays in prop::collection::vec(
            (text(), values(0..30usize), prop_oneof![3 => 1..4usize, 1 => size()], any::<bool>()),
            0..4,
        ),
        ascii in any::<bool>(),
    ) {
        let enc = if ascii { Encoding::Ascii } else { Encoding::Binary };
        // Grids.
        let valid = dims.iter().all(|&d| d >= 1)
            && dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d)).is_some()
            && origin.iter().all(|o| o.is_finite())
            && spacing.iter().all(|s| s.is_finite() && *s > 0.0);
        match ImageData::new(dims, origin, spacing) {
            Ok(g) => {
                prop_assert!(valid);
                let mut g = g.encoding(enc);
                let points = g.points();
                let mut added: Vec<Vec<f64>> = Vec::new();
                for (name, data, comps, fit) in &arrays {
                    let mut data = data.clone();
                    if *fit && points <= 30 {
                        data.resize(points * comps.min(&3), 0.25);
                    }
                    let r = if *comps == 1 {
                        g.add_scalar(name, &data).map(|_| ())
                    } else {
                        g.add_vector(name, &data, *comps).map(|_| ())
                    };
                    match r {
                        Ok(()) => added.push(data),
                        Err(e) => assert_names(&e, &["array name", ".len()", "components"]),
                    }
                }
                match g.to_xml() {
                    Ok(xml) => {
                        prop_assert!(!ascii || added.iter().flatten().all(|v| v.is_finite()));
                        check_vtk(&xml, "ImageData", added.len());
                    }
                    Err(e) => {
                        prop_assert!(ascii);
                        assert_names(&e, &["ASCII VTK"]);
                    }
                }
            }
            Err(e) => {
                prop_assert!(!valid, "valid grid refused: {}", e);
                assert_names(&e, &["dims", "origin", "spacing"]);
            }
        }
        // Particles.
        match Particles::new(&positions, dim) {
            Ok(p) => {
                prop_assert!((dim == 2 || dim == 3) && positions.len() % dim == 0);
                let mut p = p.encoding(enc);
                let n = p.len();
                prop_assert_eq!(n, positions.len() / dim);
                let mut added = 0;
                for (name, data, comps, fit) in &arrays {
                    let mut data = data.clone();
                    if *fit {
                        data.resize(n * comps.min(&3), -0.5);
                    }
                    let r = if *comps == 1 && data.iter().all(|v| v.fract() == 0.0 && v.abs() < 1e6) {
                        let ints: Vec<i32> = data.iter().map(|&v| v as i32).collect();
                        p.add_ints(name, &ints).map(|_| ())
                    } else if *comps == 1 {
                        p.add_scalar(name, &data).map(|_| ())
                    } else {
                        p.add_vector(name, &data, *comps).map(|_| ())
                    };
                    match r {
                        Ok(()) => added += 1,
                        Err(e) => assert_names(&e, &["array name", ".len()", "components"]),
                    }
                }
                match p.to_xml() {
                    Ok(xml) => check_vtk(&xml, "PolyData", added + 3),
                    Err(e) => {
                        prop_assert!(ascii);
                        assert_names(&e, &["ASCII VTK"]);
                    }
                }
            }
            Err(e) => assert_names(&e, &["dim", "positions.len()"]),
        }
    }
}

/// Species names: element symbols (which the writer takes), near misses and any text.
fn symbol() -> impl Strategy<Value = String> {
    prop_oneof![
        2 => prop::sample::select(ELEMENTS.to_vec()).prop_map(String::from),
        1 => prop::sample::select(vec!["X", "h", "AR", "A", "Xx", "H ", "He\n"]).prop_map(String::from),
        1 => text(),
    ]
}

/// Splits an extended XYZ comment line into `key=value` pairs (values may be quoted).
fn comment_pairs(line: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut rest = line.trim();
    while !rest.is_empty() {
        let eq = rest.find('=').expect("key=value");
        let key = rest[..eq].to_string();
        rest = &rest[eq + 1..];
        let (value, tail) = if let Some(q) = rest.strip_prefix('"') {
            let end = q.find('"').expect("closing quote");
            (q[..end].to_string(), &q[end + 1..])
        } else {
            let end = rest.find(' ').unwrap_or(rest.len());
            (rest[..end].to_string(), &rest[end..])
        };
        out.push((key, value));
        rest = tail.trim_start();
    }
    out
}

/// An extended XYZ frame's text: the count, a comment line with each key once and the
/// properties it announces, one line per particle with exactly the values given.
fn check_xyz(text: &str, positions: &[f64], species: &[String], columns: &[Vec<f64>]) {
    let lines: Vec<&str> = text.lines().collect();
    let n = species.len();
    assert_eq!(lines.len(), n + 2, "{text}");
    assert_eq!(lines[0], n.to_string());
    let pairs = comment_pairs(lines[1]);
    let mut keys: Vec<&str> = pairs.iter().map(|(k, _)| k.as_str()).collect();
    keys.sort_unstable();
    assert!(
        keys.windows(2).all(|w| w[0] != w[1]),
        "a key twice: {}",
        lines[1]
    );
    let props = &pairs
        .iter()
        .find(|(k, _)| k == "Properties")
        .expect("Properties")
        .1;
    let fields: Vec<&str> = props.split(':').collect();
    assert_eq!(fields.len() % 3, 0, "{props}");
    let width: usize = fields
        .chunks(3)
        .map(|f| f[2].parse::<usize>().unwrap())
        .sum();
    for (i, line) in lines[2..].iter().enumerate() {
        let tokens: Vec<&str> = line.split(' ').collect();
        assert_eq!(tokens.len(), width, "{line}");
        assert_eq!(tokens[0], species[i]);
        let nums: Vec<f64> = tokens[1..].iter().map(|t| t.parse().unwrap()).collect();
        assert_eq!(&nums[..3], &positions[3 * i..3 * i + 3]);
        let mut k = 3;
        for c in columns {
            let per = c.len() / n;
            assert_eq!(&nums[k..k + per], &c[per * i..per * (i + 1)]);
            k += per;
        }
    }
}

proptest! {
    #![proptest_config(robust::config(SEED, 2000))]

    /// Extended XYZ frames with any positions, species, cell, time, info and columns.
    #[test]
    fn xyz_frames_or_refusals(
        positions in values(0..13usize),
        dim in prop_oneof![4 => 2..4usize, 1 => size()],
        names in prop::collection::vec(symbol(), 0..6),
        uniform in prop::option::weighted(0.3, symbol()),
        lattice in prop::option::weighted(0.3, prop::array::uniform3(prop::array::uniform3(mostly(0.0..5.0)))),
        boxed in prop::option::weighted(0.3, (awkward_f64(), awkward_f64())),
        pbc in prop::option::of(any::<[bool; 3]>()),
        time in prop::option::of(awkward_f64()),
        info in prop::collection::vec((text(), awkward_f64()), 0..4),
        cols in prop::collection::vec((text(), values(0..20usize), prop_oneof![3 => 1..4usize, 1 => size()], any::<bool>()), 0..3),
    ) {
        let frame = XyzFrame::new(&positions, dim);
        let valid = (dim == 2 || dim == 3)
            && positions.len() % dim == 0
            && positions.iter().all(|v| v.is_finite());
        let mut f = match frame {
            Ok(f) => {
                prop_assert!(valid);
                f
            }
            Err(e) => {
                prop_assert!(!valid, "valid positions refused: {}", e);
                assert_names(&e, &["dim", "positions.len()", "position["]);
                return Ok(());
            }
        };
        let n = f.len();
        let word = |s: &str| s == "X" || ELEMENTS.contains(&s);
        let mut species = vec!["X".to_string(); n];
        match f.species(&names) {
            Ok(_) => {
                prop_assert!(names.len() == n && names.iter().all(|s| word(s)));
                species.clone_from(&names);
            }
            Err(e) => {
                prop_assert!(names.len() != n || !names.iter().all(|s| word(s)));
                assert_names(&e, &["species"]);
            }
        }
        if let Some(u) = &uniform {
            match f.uniform_species(u) {
                Ok(_) => {
                    prop_assert!(word(u));
                    species = vec![u.clone(); n];
                }
                Err(e) => assert_names(&e, &["species"]),
            }
        }
        if let Some(cell) = lattice {
            let r = f.lattice(cell).map(|_| ());
            prop_assert_eq!(r.is_ok(), cell.iter().flatten().all(|v| v.is_finite()));
        }
        if let Some((lx, ly)) = boxed {
            match f.box_2d(lx, ly) {
                Ok(_) => prop_assert!(lx.is_finite() && lx > 0.0 && ly.is_finite() && ly > 0.0),
                Err(e) => assert_names(&e, &["lx", "ly"]),
            }
        }
        if let Some(p) = pbc {
            f.pbc(p);
        }
        if let Some(t) = time {
            prop_assert_eq!(f.time(t).is_ok(), t.is_finite());
        }
        for (key, value) in &info {
            if let Err(e) = f.info(key, *value) {
                assert_names(&e, &["info key", "property name", key.as_str()]);
            }
        }
        let mut columns = Vec::new();
        for (name, data, comps, fit) in &cols {
            let mut data = data.clone();
            if *fit {
                data.resize(n * comps.min(&3), 2.5);
            }
            let r = if *comps == 1 {
                f.add_scalar(name, &data).map(|_| ())
            } else {
                f.add_vector(name, &data, *comps).map(|_| ())
            };
            match r {
                Ok(()) => {
                    // Written with 1 or 3 components (2 padded with a zero z).
                    let c: Vec<f64> = if *comps == 2 {
                        data.chunks(2).flat_map(|v| [v[0], v[1], 0.0]).collect()
                    } else {
                        data
                    };
                    columns.push(c);
                }
                Err(e) => assert_names(&e, &["property name", ".len()", "components", "["]),
            }
        }
        let mut text = String::new();
        f.write_to(&mut text);
        let padded: Vec<f64> = if dim == 2 {
            positions.chunks(2).flat_map(|v| [v[0], v[1], 0.0]).collect()
        } else {
            positions.clone()
        };
        if n > 0 {
            check_xyz(&text, &padded, &species, &columns);
        } else {
            prop_assert!(text.starts_with("0\n"));
        }
    }
}

proptest! {
    #![proptest_config(robust::config(SEED, 3000))]

    /// Colour maps and number formats with any values: never a panic or a hang.
    #[test]
    fn colors_and_numbers(
        t in awkward_f64(),
        (v, lo, hi) in (awkward_f64(), awkward_f64(), awkward_f64()),
        step in awkward_f64(),
    ) {
        for cmap in [Colormap::Viridis, Colormap::Diverging, Colormap::Gray] {
            let c = cmap.map(t);
            prop_assert_eq!(c == NAN_COLOR, t.is_nan());
            let c = cmap.map_range(v, lo, hi);
            prop_assert_eq!(c == NAN_COLOR, v.is_nan());
            prop_assert!((0.0..=255.0).contains(&luminance(c)));
        }
        // Exact numbers parse back bit for bit; labels parse back close to the value.
        let e = numfmt::exact(v);
        if v.is_nan() {
            prop_assert_eq!(e, "NaN");
        } else {
            prop_assert_eq!(e.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{}", e);
        }
        for label in [numfmt::short(v), numfmt::tick(v, step)] {
            if v.is_finite() {
                let back: f64 = label.parse().unwrap();
                prop_assert!(back.is_finite(), "{} -> {}", v, label);
            } else {
                prop_assert!(["NaN", "inf", "-inf"].contains(&label.as_str()));
            }
        }
        if v.is_finite() && v != 0.0 {
            let back: f64 = numfmt::short(v).parse().unwrap();
            // Three significant digits (plus half a step of the subnormal grid).
            prop_assert!(abs_diff_eq!(back, v, epsilon = 0.005 * v.abs() + 5e-324), "{} -> {}", v, back);
        }

    }

}

/// A temporary directory for one test, empty.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "simkit-output-robustness-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Where a file is written.
#[derive(Clone, Copy, Debug)]
enum Target {
    /// A new file in an existing directory.
    New,
    /// An existing file (to be replaced).
    Existing,
    /// A file in directories that do not exist yet (created).
    NewDirectories,
    /// A path whose parent is a regular file: cannot be created.
    UnderAFile,
    /// An existing directory: cannot be replaced by a file.
    Directory,
    /// The empty path: no file name.
    Empty,
}

/// One of the writers of this crate, with data that may or may not be valid.
#[derive(Clone, Debug)]
enum Writer {
    Csv(Vec<String>, Vec<Vec<f64>>),
    CsvStream(Vec<String>, Vec<Vec<f64>>),
    Pvd(Vec<f64>, String),
    Vti(usize, Vec<f64>),
    Vtu(Vec<f64>),
    Xyz(Vec<f64>),
    XyzStream(Vec<f64>),
    Heatmap(usize, Vec<f64>),
    VectorField(usize, Vec<f64>),
    Plot(Vec<f64>),
    Png(u32, u32),
    Gif(Vec<(u32, u32)>, u32),
    GifStream(Vec<(u32, u32)>, u32),
}

fn writer() -> impl Strategy<Value = Writer> {
    let rows = || prop::collection::vec(values(0..4usize), 0..4);
    let names = || prop::collection::vec(text(), 0..4);
    let frames = prop_oneof![
        // Valid frames, or any mix of sizes (mismatched, empty, too wide).
        2 => prop::collection::vec(Just((3u32, 2u32)), 1..3),
        1 => prop::collection::vec(
            prop::sample::select(vec![(3, 2), (2, 3), (0, 4), (70_000, 1)]),
            0..4,
        ),
    ];
    let delay = prop_oneof![6 => 0..1000u32, 1 => Just(MAX_DELAY_MS), 1 => any::<u32>()];
    prop_oneof![
        (names(), rows()).prop_map(|(n, r)| Writer::Csv(n, r)),
        (names(), rows()).prop_map(|(n, r)| Writer::CsvStream(n, r)),
        (values(0..4usize), text()).prop_map(|(t, name)| Writer::Pvd(t, name)),
        (0..4usize, values(0..10usize)).prop_map(|(k, v)| Writer::Vti(k, v)),
        values(0..10usize).prop_map(Writer::Vtu),
        values(0..10usize).prop_map(Writer::Xyz),
        values(0..10usize).prop_map(Writer::XyzStream),
        (0..4usize, values(0..10usize)).prop_map(|(k, v)| Writer::Heatmap(k, v)),
        (0..4usize, values(0..10usize)).prop_map(|(k, v)| Writer::VectorField(k, v)),
        values(0..6usize).prop_map(Writer::Plot),
        (0..5u32, 0..5u32).prop_map(|(w, h)| Writer::Png(w, h)),
        (frames.clone(), delay.clone()).prop_map(|(f, d)| Writer::Gif(f, d)),
        (frames, delay).prop_map(|(f, d)| Writer::GifStream(f, d)),
    ]
}

/// Runs `writer` on `path`; returns what it wrote must start with.
fn write(writer: &Writer, path: &Path) -> (simkit_backend::Result<()>, &'static [u8]) {
    let frames = |sizes: &[(u32, u32)]| -> Vec<RgbImage> {
        sizes
            .iter()
            .map(|&(w, h)| RgbImage::from_pixel(w, h, Rgb([10, 200, 30])))
            .collect()
    };
    match writer {
        Writer::Csv(names, rows) => (write_csv(path, names, rows), b""),
        Writer::CsvStream(names, rows) => (
            (|| {
                let mut csv = CsvWriter::create(path, names)?;
                for r in rows {
                    csv.row(r)?;
                }
                csv.finish()
            })(),
            b"",
        ),
        Writer::Pvd(times, name) => {
            let entries: Vec<(f64, String)> = times
                .iter()
                .enumerate()
                .map(|(i, &t)| (t, format!("{name}_{i}.vtp")))
                .collect();
            (write_pvd(path, &entries), b"<?xml")
        }
        Writer::Vti(k, v) => (
            (|| {
                let mut g = ImageData::new_2d(*k, 2, [0.0; 2], [1.0; 2])?;
                g.add_scalar("v", v)?;
                g.write(path)
            })(),
            b"<?xml",
        ),
        Writer::Vtu(v) => (
            (|| Particles::new(v, 2)?.encoding(Encoding::Ascii).write(path))(),
            b"<?xml",
        ),
        Writer::Xyz(v) => ((|| write_xyz(path, &[XyzFrame::new(v, 3)?]))(), b""),
        Writer::XyzStream(v) => (
            (|| {
                let mut traj = XyzWriter::create(path)?;
                traj.push(&XyzFrame::new(v, 2)?)?;
                traj.finish()
            })(),
            b"",
        ),
        Writer::Heatmap(w, v) => (
            write_heatmap(path, v, *w, 2, &HeatmapOptions::new()).map(|_| ()),
            b"\x89PNG",
        ),
        Writer::VectorField(w, v) => (
            write_vector_field(path, v, v, *w, 2, &VectorFieldOptions::new()).map(|_| ()),
            b"\x89PNG",
        ),
        Writer::Plot(y) => {
            let x: Vec<f64> = (0..y.len()).map(|i| i as f64).collect();
            (
                Plot::new("p")
                    .size(120, 90)
                    .series(Series::line("y", &x, y))
                    .write(path),
                b"\x89PNG",
            )
        }
        Writer::Png(w, h) => (png::write_png(path, &RgbImage::new(*w, *h)), b"\x89PNG"),
        Writer::Gif(sizes, delay) => (write_gif(path, &frames(sizes), *delay), b"GIF89a"),
        Writer::GifStream(sizes, delay) => (
            (|| {
                let mut g = GifWriter::create(path, *delay)?;
                for f in frames(sizes) {
                    g.push(&f)?;
                }
                g.finish()
            })(),
            b"GIF89a",
        ),
    }
}

/// Names in `dir` that look like temporary files of an atomic write.
fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.contains(".tmp-"))
                .collect()
        })
        .unwrap_or_default()
}

proptest! {
    #![proptest_config(robust::config(SEED, 400))]

    /// Every writer, valid data or not, to a good or an impossible path: `Ok` leaves the new
    /// file in place, `Err` leaves the previous file untouched; no temporary file either
    /// way, and an impossible path is an error naming it.
    #[test]
    fn files_are_written_atomically_or_not_at_all(
        target in prop::sample::select(vec![
            Target::New, Target::Existing, Target::NewDirectories, Target::UnderAFile,
            Target::Directory, Target::Empty,
        ]),
        w in writer(),
    ) {
        let dir = scratch("files");
        let old = b"previous content".to_vec();
        let path = match target {
            Target::New => dir.join("out.dat"),
            Target::Existing => {
                std::fs::write(dir.join("out.dat"), &old).unwrap();
                dir.join("out.dat")
            }
            Target::NewDirectories => dir.join("a/b/out.dat"),
            Target::UnderAFile => {
                std::fs::write(dir.join("file"), &old).unwrap();
                dir.join("file/out.dat")
            }
            Target::Directory => {
                std::fs::create_dir_all(dir.join("sub/inner")).unwrap();
                dir.join("sub")
            }
            Target::Empty => PathBuf::new(),
        };
        let (result, magic) = write(&w, &path);
        match &result {
            Ok(()) => {
                prop_assert!(matches!(target, Target::New | Target::Existing | Target::NewDirectories));
                let bytes = std::fs::read(&path).unwrap();
                prop_assert!(bytes.starts_with(magic), "{:?}", &bytes[..bytes.len().min(16)]);
                prop_assert_ne!(&bytes, &old);
                if let Writer::Pvd(_, name) = &w {
                    prop_assert!(!name.chars().any(char::is_control));
                    prop_assert!(!String::from_utf8_lossy(&bytes).chars().any(|c| c.is_control() && c != '\n'));
                }
                // Images decode.
                if magic == b"\x89PNG" {
                    prop_assert!(image::load_from_memory(&bytes).is_ok());
                }
                if let Writer::Gif(sizes, delay) | Writer::GifStream(sizes, delay) = &w {
                    let decoder = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(bytes)).unwrap();
                    let frames = decoder.into_frames().collect_frames().unwrap();
                    prop_assert_eq!(frames.len(), sizes.len());
                    prop_assert!(*delay <= MAX_DELAY_MS);
                    let (ms, den) = frames[0].delay().numer_denom_ms();
                    prop_assert_eq!(ms / den, delay / 10 * 10);
                }
            }
            Err(e) => {
                match target {
                    Target::Existing => prop_assert_eq!(std::fs::read(&path).unwrap(), old.clone()),
                    Target::New | Target::NewDirectories => prop_assert!(!path.exists()),
                    Target::UnderAFile => {
                        prop_assert_eq!(std::fs::read(dir.join("file")).unwrap(), old.clone());
                    }
                    Target::Directory => prop_assert!(dir.join("sub/inner").is_dir()),
                    Target::Empty => {}
                }
                if let Error::Io { path: p, .. } = e {
                    prop_assert!(p.contains("out.dat") || p.contains("file") || p.contains("sub"), "{}", e);
                }
            }
        }
        for d in [dir.clone(), dir.join("a/b"), dir.join("sub")] {
            prop_assert!(leftovers(&d).is_empty(), "temporary files left in {:?}", d);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// A CSV file parses back to the exact values (NaN and infinities included).
#[test]
fn csv_values_parse_back_exactly() {
    let dir = scratch("csv");
    let path = dir.join("v.csv");
    let rows = vec![
        vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY],
        vec![5e-324, f64::MAX, -0.0],
        vec![0.1, 1e300, f64::MIN_POSITIVE],
    ];
    write_csv(&path, &["a", "b,c", "d\"e"], &rows).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("a,\"b,c\",\"d\"\"e\""));
    for (line, row) in lines.zip(&rows) {
        let back: Vec<f64> = line.split(',').map(|t| t.parse().unwrap()).collect();
        for (b, v) in back.iter().zip(row) {
            assert!(
                b.to_bits() == v.to_bits() || b.is_nan() && v.is_nan(),
                "{b} {v}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A GIF's delay is stored in hundredths of a second (at most 65535): a longer one used to be
/// clamped without a word, it is now an error naming it.
#[test]
fn gif_delays_over_the_format_limit_are_errors() {
    let dir = scratch("gif");
    let frame = RgbImage::new(2, 2);
    write_gif(
        dir.join("ok.gif"),
        std::slice::from_ref(&frame),
        MAX_DELAY_MS,
    )
    .unwrap();
    let bytes = std::fs::read(dir.join("ok.gif")).unwrap();
    let decoder = image::codecs::gif::GifDecoder::new(std::io::Cursor::new(bytes)).unwrap();
    let frames = decoder.into_frames().collect_frames().unwrap();
    assert_eq!(frames[0].delay().numer_denom_ms(), (MAX_DELAY_MS, 1));
    let e = write_gif(dir.join("long.gif"), &[frame], MAX_DELAY_MS + 1).unwrap_err();
    assert!(
        e.to_string().contains("delay_ms") && e.to_string().contains("655351"),
        "{e}"
    );
    assert!(!dir.join("long.gif").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Heat maps of values at the ends of `f64` get a finite range and distinct colours.
#[test]
fn heatmaps_of_extreme_values_use_the_whole_colour_map() {
    let o = HeatmapOptions::new().colorbar(false);
    let (img, range) = render_heatmap(&[f64::MAX], 1, 1, &o).unwrap();
    assert!(
        range.0.is_finite() && range.1.is_finite() && range.0 < range.1,
        "{range:?}"
    );
    assert!(img.pixels().any(|p| p.0 == Colormap::Viridis.map(1.0)));
    let (img, range) = render_heatmap(&[-1e308, 1e308], 2, 1, &o).unwrap();
    assert_eq!(range, (-1e308, 1e308));
    assert!(img.pixels().any(|p| p.0 == Colormap::Viridis.map(0.0)));
    assert!(img.pixels().any(|p| p.0 == Colormap::Viridis.map(1.0)));
    let (_, range) = render_heatmap(&[5e-324], 1, 1, &o).unwrap();
    assert!(range.0 < 5e-324 && 5e-324 < range.1, "{range:?}");
}

/// Images over the area limit are refused before anything is allocated (a 1 x 1 field at
/// upscale 2^15, or a 2^15 x 2^15 plot, used to allocate 3 GiB).
#[test]
fn images_over_the_pixel_limit_are_refused_before_allocating() {
    let o = HeatmapOptions::new().colorbar(false).upscale(1 << 15);
    let e = render_heatmap(&[1.0], 1, 1, &o).unwrap_err().to_string();
    assert!(e.contains("upscale") && e.contains("pixels in all"), "{e}");
    let side = MAX_SIDE as u32;
    let e = Plot::new("big")
        .size(side, side)
        .series(Series::line("y", &[0.0, 1.0], &[1.0, 2.0]))
        .render()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("plot size") && e.contains("pixels in all"),
        "{e}"
    );
}

/// Keys that the XYZ comment line already has are refused instead of written twice.
#[test]
fn xyz_info_keys_are_unique() {
    let mut f = XyzFrame::from_xyz(&[[0.0; 3]]).unwrap();
    f.time(1.0).unwrap().info("energy", 2.0).unwrap();
    for key in ["energy", "Time", "time", "Properties", "Lattice", "PBC"] {
        let e = f.info(key, 3.0).unwrap_err().to_string();
        assert!(e.contains("info key") && e.contains(key), "{e}");
    }
    let e = f.species(&["A\u{7}"]).unwrap_err().to_string();
    assert!(e.contains("species[0]"), "{e}");
    let mut out = String::new();
    f.write_to(&mut out);
    assert_eq!(out.matches("Time=").count(), 1, "{out}");
}
