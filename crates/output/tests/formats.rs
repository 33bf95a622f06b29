//! VTK, extended XYZ and CSV files parse back with the right structure and counts, and with
//! the values written, bit for bit (small parsers in this file read them back: XML with
//! base64 arrays decoded by their declared header type, extended XYZ by its `Properties`).

use std::collections::HashMap;
use std::path::PathBuf;

use simkit_output::csv::{CsvWriter, write_csv};
use simkit_output::numfmt;
use simkit_output::vtk::{Encoding, ImageData, Particles, write_pvd};
use simkit_output::xyz::{XyzFrame, XyzWriter, write_xyz};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("simkit-output-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A parsed XML element: name, attributes, text, children.
#[derive(Debug)]
struct Elem {
    name: String,
    attrs: HashMap<String, String>,
    text: String,
    children: Vec<Elem>,
}

impl Elem {
    fn child(&self, name: &str) -> &Elem {
        self.children
            .iter()
            .find(|c| c.name == name)
            .unwrap_or_else(|| panic!("<{}> has no <{name}>", self.name))
    }
    fn attr(&self, a: &str) -> &str {
        self.attrs
            .get(a)
            .unwrap_or_else(|| panic!("<{}> has no {a}", self.name))
    }
    /// An attribute with the XML entities of attribute values decoded.
    fn attr_text(&self, a: &str) -> String {
        let mut out = String::new();
        let mut rest = self.attr(a);
        while let Some(amp) = rest.find('&') {
            out.push_str(&rest[..amp]);
            let semi = rest[amp..].find(';').expect("entity without ';'") + amp;
            out.push(match &rest[amp + 1..semi] {
                "amp" => '&',
                "lt" => '<',
                "gt" => '>',
                "quot" => '"',
                "apos" => '\'',
                e => panic!("unknown entity &{e};"),
            });
            rest = &rest[semi + 1..];
        }
        out.push_str(rest);
        out
    }
    fn arrays(&self) -> Vec<&Elem> {
        self.children
            .iter()
            .filter(|c| c.name == "DataArray")
            .collect()
    }
}

/// A strict little XML parser for the subset VTK files use; panics on malformed input.
fn parse_xml(s: &str) -> Elem {
    let s = s.trim_start();
    let s = if s.starts_with("<?xml") {
        &s[s.find("?>").unwrap() + 2..]
    } else {
        s
    };
    let mut pos = 0;
    let root = parse_elem(s, &mut pos);
    assert!(s[pos..].trim().is_empty(), "trailing content after root");
    root
}

fn parse_elem(s: &str, pos: &mut usize) -> Elem {
    let rest = &s[*pos..];
    let start = rest.find('<').unwrap();
    assert!(rest[..start].trim().is_empty(), "text outside elements");
    let end = rest[start..].find('>').unwrap() + start;
    let tag = &rest[start + 1..end];
    let self_closing = tag.ends_with('/');
    let tag = tag.trim_end_matches('/');
    let mut parts = tag.splitn(2, char::is_whitespace);
    let name = parts.next().unwrap().to_string();
    let mut attrs = HashMap::new();
    let mut a = parts.next().unwrap_or("").trim();
    while !a.is_empty() {
        let eq = a.find('=').unwrap();
        let key = a[..eq].trim().to_string();
        let after = a[eq + 1..].trim_start();
        assert!(after.starts_with('"'), "unquoted attribute {key}");
        let close = after[1..].find('"').unwrap() + 1;
        assert!(
            attrs
                .insert(key.clone(), after[1..close].to_string())
                .is_none(),
            "duplicate {key}"
        );
        a = after[close + 1..].trim_start();
    }
    *pos += end + 1;
    let mut e = Elem {
        name,
        attrs,
        text: String::new(),
        children: Vec::new(),
    };
    if self_closing {
        return e;
    }
    loop {
        let rest = &s[*pos..];
        let lt = rest.find('<').unwrap();
        if rest[lt..].starts_with("</") {
            e.text.push_str(rest[..lt].trim());
            let gt = rest[lt..].find('>').unwrap() + lt;
            assert_eq!(&rest[lt + 2..gt], e.name, "mismatched closing tag");
            *pos += gt + 1;
            return e;
        }
        assert!(
            rest[..lt].trim().is_empty(),
            "mixed content in <{}>",
            e.name
        );
        let child = parse_elem(s, pos);
        e.children.push(child);
    }
}

fn b64_decode(s: &str) -> Vec<u8> {
    let val = |c: u8| -> u32 {
        match c {
            b'A'..=b'Z' => (c - b'A') as u32,
            b'a'..=b'z' => (c - b'a' + 26) as u32,
            b'0'..=b'9' => (c - b'0' + 52) as u32,
            b'+' => 62,
            b'/' => 63,
            _ => panic!("bad base64 char {c}"),
        }
    };
    let bytes: Vec<u8> = s.bytes().filter(|c| !c.is_ascii_whitespace()).collect();
    assert_eq!(bytes.len() % 4, 0);
    let mut out = Vec::new();
    for q in bytes.chunks(4) {
        let pad = q.iter().filter(|&&c| c == b'=').count();
        let n = q
            .iter()
            .take(4 - pad)
            .enumerate()
            .fold(0u32, |n, (i, &c)| n | val(c) << (18 - 6 * i));
        out.extend_from_slice(&n.to_be_bytes()[1..4 - pad]);
    }
    out
}

/// The type of the byte count before each binary array: the root's `header_type`, which
/// every file declares (readers disagree on the default when it is missing).
fn header_type(root: &Elem) -> &str {
    root.attr("header_type")
}

/// Values of a DataArray (binary or ascii) as f64; `header` from [`header_type`].
fn values(a: &Elem, header: &str) -> Vec<f64> {
    match a.attr("format") {
        "ascii" => a
            .text
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect(),
        "binary" => {
            let raw = b64_decode(&a.text);
            let (n, data) = match header {
                "UInt32" => (
                    u32::from_le_bytes(raw[..4].try_into().unwrap()) as usize,
                    &raw[4..],
                ),
                "UInt64" => (
                    u64::from_le_bytes(raw[..8].try_into().unwrap()) as usize,
                    &raw[8..],
                ),
                h => panic!("unexpected header_type {h}"),
            };
            assert_eq!(n, data.len(), "binary header byte count");
            match a.attr("type") {
                "Float64" => data
                    .chunks(8)
                    .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
                "Int64" => data
                    .chunks(8)
                    .map(|c| i64::from_le_bytes(c.try_into().unwrap()) as f64)
                    .collect(),
                t => panic!("unexpected type {t}"),
            }
        }
        f => panic!("unexpected format {f}"),
    }
}

fn check_header(root: &Elem, kind: &str) {
    assert_eq!(root.name, "VTKFile");
    assert_eq!(root.attr("type"), kind);
    assert_eq!(root.attr("version"), "0.1");
    assert_eq!(root.attr("byte_order"), "LittleEndian");
    assert_eq!(root.attr("header_type"), "UInt64");
}

#[test]
fn vti_parses_back() {
    let dir = tmp("vti");
    for enc in [Encoding::Binary, Encoding::Ascii] {
        let (nx, ny, nz) = (4, 3, 2);
        let n = nx * ny * nz;
        let rho: Vec<f64> = (0..n).map(|i| i as f64 * 0.5).collect();
        let vel: Vec<f32> = (0..2 * n).map(|i| i as f32).collect();
        let mut g = ImageData::new([nx, ny, nz], [0.0, -1.0, 0.5], [0.1, 0.2, 0.3])
            .unwrap()
            .encoding(enc);
        g.add_scalar("rho", &rho)
            .unwrap()
            .add_vector("u", &vel, 2)
            .unwrap();
        let path = dir.join(format!("grid_{enc:?}.vti"));
        g.write(&path).unwrap();
        let root = parse_xml(&std::fs::read_to_string(&path).unwrap());
        check_header(&root, "ImageData");
        let img = root.child("ImageData");
        assert_eq!(img.attr("WholeExtent"), "0 3 0 2 0 1");
        assert_eq!(img.attr("Spacing"), "0.1 0.2 0.3");
        assert_eq!(img.attr("Origin"), "0 -1 0.5");
        let piece = img.child("Piece");
        assert_eq!(piece.attr("Extent"), "0 3 0 2 0 1");
        let pd = piece.child("PointData");
        assert_eq!(pd.attr("Scalars"), "rho");
        assert_eq!(pd.attr("Vectors"), "u");
        let arrays = pd.arrays();
        assert_eq!(arrays.len(), 2);
        assert_eq!(arrays[0].attr("Name"), "rho");
        assert_eq!(values(arrays[0], header_type(&root)), rho);
        assert_eq!(arrays[1].attr("NumberOfComponents"), "3");
        let u = values(arrays[1], header_type(&root));
        assert_eq!(u.len(), 3 * n);
        assert_eq!(&u[..6], &[0.0, 1.0, 0.0, 2.0, 3.0, 0.0]);
    }
    // 2D convenience.
    let g = ImageData::new_2d(5, 4, [0.0, 0.0], [1.0, 1.0]).unwrap();
    assert_eq!(g.points(), 20);
    assert!(g.to_xml().unwrap().contains("WholeExtent=\"0 4 0 3 0 0\""));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn vtp_parses_back() {
    let dir = tmp("vtp");
    for enc in [Encoding::Binary, Encoding::Ascii] {
        let n = 5;
        let pos: Vec<f32> = (0..2 * n).map(|i| i as f32 * 0.25).collect();
        let mut p = Particles::new(&pos, 2).unwrap().encoding(enc);
        let radius: Vec<f64> = (0..n).map(|i| 0.1 + i as f64 * 0.01).collect();
        let species: Vec<u32> = (0..n as u32).map(|i| i % 2).collect();
        let ids: Vec<i64> = (0..n as i64).map(|i| 1000 - 7 * i).collect();
        let vel: Vec<f64> = (0..3 * n).map(|i| -(i as f64)).collect();
        p.add_scalar("radius", &radius)
            .unwrap()
            .add_ints("species", &species)
            .unwrap()
            .add_ints("id", &ids)
            .unwrap()
            .add_vector("velocity", &vel, 3)
            .unwrap();
        assert_eq!(p.len(), n);
        let path = dir.join(format!("particles_{enc:?}.vtp"));
        p.write(&path).unwrap();
        let root = parse_xml(&std::fs::read_to_string(&path).unwrap());
        check_header(&root, "PolyData");
        let hdr = header_type(&root);
        let piece = root.child("PolyData").child("Piece");
        assert_eq!(piece.attr("NumberOfPoints"), "5");
        assert_eq!(piece.attr("NumberOfVerts"), "5");
        for other in ["NumberOfLines", "NumberOfStrips", "NumberOfPolys"] {
            assert_eq!(piece.attr(other), "0", "{other}");
        }
        let points = piece.child("Points").arrays();
        assert_eq!(points.len(), 1);
        assert_eq!(points[0].attr("NumberOfComponents"), "3");
        let xyz = values(points[0], hdr);
        assert_eq!(xyz.len(), 15);
        assert_eq!(&xyz[..6], &[0.0, 0.25, 0.0, 0.5, 0.75, 0.0]);
        let verts = piece.child("Verts").arrays();
        let by_name: HashMap<&str, Vec<f64>> = verts
            .iter()
            .map(|a| (a.attr("Name"), values(a, hdr)))
            .collect();
        assert_eq!(by_name.len(), 2);
        assert_eq!(by_name["connectivity"], [0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(by_name["offsets"], [1.0, 2.0, 3.0, 4.0, 5.0]);
        let pd = piece.child("PointData");
        assert_eq!(pd.attr("Scalars"), "radius");
        assert_eq!(pd.attr("Vectors"), "velocity");
        let arrays = pd.arrays();
        let names: Vec<&str> = arrays.iter().map(|a| a.attr("Name")).collect();
        assert_eq!(names, ["radius", "species", "id", "velocity"]);
        let types: Vec<&str> = arrays.iter().map(|a| a.attr("type")).collect();
        assert_eq!(types, ["Float64", "Int64", "Int64", "Float64"]);
        for a in &arrays {
            let comps: usize = a.attr("NumberOfComponents").parse().unwrap();
            assert_eq!(values(a, hdr).len(), comps * n, "{}", a.attr("Name"));
        }
        assert_eq!(values(arrays[0], hdr), radius);
        assert_eq!(values(arrays[1], hdr), [0.0, 1.0, 0.0, 1.0, 0.0]);
        assert_eq!(values(arrays[2], hdr), [1000.0, 993.0, 986.0, 979.0, 972.0]);
        assert_eq!(values(arrays[3], hdr), vel);
    }
    // Integer arrays take part in the unique-name check and the length check.
    let mut p = Particles::from_xy(&[[0.0, 0.0], [1.0, 1.0]]).unwrap();
    p.add_scalar("radius", &[0.5, 0.5]).unwrap();
    assert!(p.add_ints("radius", &[1u32, 2]).is_err());
    assert!(p.add_ints("id", &[1u32]).is_err());
    // Empty particle sets are valid files.
    let p = Particles::from_xyz(&[]).unwrap();
    let root = parse_xml(&p.to_xml().unwrap());
    assert_eq!(
        root.child("PolyData").child("Piece").attr("NumberOfPoints"),
        "0"
    );
    // Series file.
    write_pvd(
        dir.join("series.pvd"),
        &[(0.0, "particles_Binary.vtp"), (0.5, "particles_Ascii.vtp")],
    )
    .unwrap();
    let root = parse_xml(&std::fs::read_to_string(dir.join("series.pvd")).unwrap());
    check_header(&root, "Collection");
    let sets = &root.child("Collection").children;
    assert_eq!(sets.len(), 2);
    assert_eq!(sets[1].attr("file"), "particles_Ascii.vtp");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Binary arrays are the 8-byte little-endian byte count the root declares
/// (`header_type="UInt64"`), then exactly that many bytes of values, for every array of
/// every file kind; the file's total base64 payload has no slack.
#[test]
fn binary_arrays_match_their_declared_header() {
    let n = 7;
    let mut p = Particles::new(&vec![0.5f64; 3 * n], 3).unwrap();
    p.add_scalar("radius", &vec![1.0f64; n])
        .unwrap()
        .add_ints("id", &vec![3u32; n])
        .unwrap();
    let mut g = ImageData::new_2d(5, 3, [0.0; 2], [1.0; 2]).unwrap();
    g.add_scalar("rho", &[2.0f64; 15])
        .unwrap()
        .add_vector("u", &[1.0f64; 30], 2)
        .unwrap();
    for (xml, want) in [
        (
            p.to_xml().unwrap(),
            vec![3 * n * 8, n * 8, n * 8, n * 8, n * 8],
        ),
        (g.to_xml().unwrap(), vec![15 * 8, 45 * 8]),
    ] {
        let root = parse_xml(&xml);
        assert_eq!(root.attr("header_type"), "UInt64");
        let mut sizes = Vec::new();
        let mut stack = vec![&root];
        while let Some(e) = stack.pop() {
            if e.name == "DataArray" {
                assert_eq!(e.attr("format"), "binary");
                let raw = b64_decode(&e.text);
                let declared = u64::from_le_bytes(raw[..8].try_into().unwrap()) as usize;
                assert_eq!(declared, raw.len() - 8, "{}", e.attr("Name"));
                sizes.push((e.attr("Name").to_string(), declared));
            }
            stack.extend(e.children.iter().rev());
        }
        let mut got: Vec<usize> = sizes.iter().map(|s| s.1).collect();
        got.sort_unstable();
        let mut want = want;
        want.sort_unstable();
        assert_eq!(got, want, "{sizes:?}");
    }
}

#[test]
fn xyz_parses_back() {
    let dir = tmp("xyz");
    let path = dir.join("traj.xyz");
    let mut w = XyzWriter::create(&path).unwrap();
    for step in 0..4 {
        let n = 3 + step;
        let pos: Vec<f64> = (0..2 * n).map(|i| i as f64 * 0.1 + step as f64).collect();
        let mut f = XyzFrame::new(&pos, 2).unwrap();
        let kinds: Vec<u32> = (0..n as u32).map(|i| i % 2).collect();
        f.kinds(&kinds, &["A", "B"])
            .unwrap()
            .box_2d(10.0, 5.0)
            .unwrap()
            .time(step as f64 * 0.5)
            .unwrap();
        f.radii(&vec![0.5f32; n]).unwrap();
        f.velocities(&vec![1.0; 2 * n], 2).unwrap();
        w.push(&f).unwrap();
    }
    assert_eq!(w.frames(), 4);
    assert!(!path.exists(), "appears only on finish");
    w.finish().unwrap();

    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines = text.lines();
    let mut frames = 0;
    while let Some(count) = lines.next() {
        let n: usize = count.trim().parse().unwrap();
        assert_eq!(n, 3 + frames);
        let comment = lines.next().unwrap();
        assert!(
            comment.contains("Lattice=\"10 0 0 0 5 0 0 0 1\""),
            "{comment}"
        );
        assert!(
            comment.contains("Properties=species:S:1:pos:R:3:kind:S:1:Radius:R:1:velo:R:3"),
            "{comment}"
        );
        assert!(
            comment.contains(&format!("Time={}", frames as f64 * 0.5)),
            "{comment}"
        );
        assert!(comment.contains("pbc=\"T T F\""), "{comment}");
        for k in 0..n {
            let cols: Vec<&str> = lines.next().unwrap().split_whitespace().collect();
            assert_eq!(cols.len(), 1 + 3 + 1 + 1 + 3);
            // Species index 0 is written as hydrogen, 1 as helium; the names follow.
            assert_eq!(cols[0], if k % 2 == 0 { "H" } else { "He" });
            assert_eq!(cols[4], if k % 2 == 0 { "A" } else { "B" });
            assert_eq!(cols[3], "0");
            assert_eq!(&cols[5..], ["0.5", "1", "1", "0"]);
            assert!(cols[1..4].iter().all(|c| c.parse::<f64>().is_ok()));
        }
        frames += 1;
    }
    assert_eq!(frames, 4);

    // Whole-file writer and validation.
    let f = XyzFrame::from_xyz(&[[0.0, 1.0, 2.0]]).unwrap();
    write_xyz(dir.join("one.xyz"), &[f.clone(), f.clone()]).unwrap();
    assert_eq!(
        std::fs::read_to_string(dir.join("one.xyz"))
            .unwrap()
            .lines()
            .count(),
        6
    );
    let mut g = f.clone();
    assert!(g.species(&["H", "He"]).is_err());
    // ASE reads the species column as element symbols: other names go through `kinds`.
    for bad in ["A", "two words", "h", "Xx", ""] {
        assert!(g.species(&[bad]).is_err(), "{bad:?}");
        assert!(g.uniform_species(bad).is_err(), "{bad:?}");
    }
    for good in ["H", "Og", "Ar", "X"] {
        g.species(&[good]).unwrap();
    }
    assert!(g.kinds(&[1u32], &["solid"]).is_err(), "index out of range");
    assert!(g.kinds(&[0u32, 0], &["solid"]).is_err(), "one per particle");
    assert!(g.kinds(&[0u32], &["two words"]).is_err());
    let many: Vec<String> = (0..119).map(|k| format!("s{k}")).collect();
    assert!(g.kinds(&[0u32], &many).is_err(), "more kinds than elements");
    g.kinds(&[117u32], &many[..118]).unwrap();
    for reserved in ["kind", "species", "pos"] {
        assert!(g.add_scalar(reserved, &[1.0]).is_err(), "{reserved}");
    }
    let mut text = String::new();
    g.write_to(&mut text);
    assert_eq!(text.lines().nth(2).unwrap(), "Og 0 1 2 s117");
    // Element symbols set afterwards drop the kind column.
    g.uniform_species("Ar").unwrap();
    text.clear();
    g.write_to(&mut text);
    assert!(!text.contains("kind"), "{text}");
    assert!(g.add_scalar("bad name", &[1.0]).is_err());
    assert!(g.add_scalar("r", &[f64::NAN]).is_err());
    assert!(XyzFrame::from_xy(&[[f64::INFINITY, 0.0]]).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn csv_parses_back() {
    let dir = tmp("csv");
    let path = dir.join("series.csv");
    let mut w = CsvWriter::create(&path, &["t", "energy", "a,b"]).unwrap();
    for i in 0..10 {
        let t = i as f64 * 0.1;
        w.row(&[t, 1e-300 * t, f64::NAN]).unwrap();
    }
    let e = w.row(&[1.0, 2.0]).unwrap_err().to_string();
    assert!(e.contains("expected 3"), "{e}");
    assert_eq!(w.rows(), 10);
    assert!(!path.exists());
    w.finish().unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 11);
    assert_eq!(lines[0], "t,energy,\"a,b\"");
    for (i, l) in lines[1..].iter().enumerate() {
        let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(v.len(), 3);
        assert_eq!(v[0], i as f64 * 0.1);
        assert_eq!(v[1], 1e-300 * (i as f64 * 0.1));
        assert!(v[2].is_nan());
    }

    write_csv(
        dir.join("whole.csv"),
        &["a", "b"],
        &[[1.0, 2.0], [3.0, 4.0]],
    )
    .unwrap();
    assert_eq!(
        std::fs::read_to_string(dir.join("whole.csv")).unwrap(),
        "a,b\n1,2\n3,4\n"
    );
    assert!(write_csv(dir.join("bad.csv"), &["a", "b"], &[vec![1.0]]).is_err());
    assert!(!dir.join("bad.csv").exists());
    assert!(CsvWriter::create(dir.join("none.csv"), &[] as &[&str]).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Values that a text format must not round: decimal fractions with no finite binary form,
/// repeating fractions, the extremes, subnormals, both zeros, integers up to 2^53, and the
/// neighbours of the points where `numfmt::exact` switches between plain and exponent form.
fn awkward() -> Vec<f64> {
    let v = vec![
        0.1,
        1.0 / 3.0,
        -2.0 / 3.0,
        1e-300,
        -2.5e300,
        f64::MIN_POSITIVE / 3.0,
        -5e-324,
        f64::MIN_POSITIVE.next_down(),
        f64::MIN_POSITIVE,
        0.0,
        -0.0,
        f64::MAX,
        f64::MIN,
        0.30000000000000004,
        1e-5,
        1e-5f64.next_down(),
        1e16,
        1e16f64.next_down(),
        9_007_199_254_740_992.0,
        123_456_789.0,
        -7.0,
        std::f64::consts::PI,
        f64::EPSILON,
    ];
    assert_eq!(v.iter().filter(|x| x.is_subnormal()).count(), 3);
    v
}

/// Integers given as `u32` (written as `f64`, exact up to 2^53).
fn awkward_ints(n: usize) -> Vec<u32> {
    (0..n)
        .map(|i| [0, 1, 7, 123_456_789, u32::MAX][i % 5])
        .collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// 2-component vectors as written: padded with `+0` to 3.
fn padded(v2: &[f64]) -> Vec<f64> {
    v2.chunks(2).flat_map(|c| [c[0], c[1], 0.0]).collect()
}

/// Three numbers of an attribute such as `Origin="a b c"`.
fn three(s: &str) -> Vec<f64> {
    let v: Vec<f64> = s.split(' ').map(|x| x.parse().unwrap()).collect();
    assert_eq!(v.len(), 3, "{s}");
    v
}

#[test]
fn vtk_values_read_back_bit_for_bit() {
    let dir = tmp("vtk-exact");
    let vals = awkward();
    let n = vals.len();
    let ints = awkward_ints(n);
    let ints_f: Vec<f64> = ints.iter().map(|&i| f64::from(i)).collect();
    let vec2: Vec<f64> = vals
        .iter()
        .zip(vals.iter().rev())
        .flat_map(|(&a, &b)| [a, b])
        .collect();
    let xyz: Vec<f64> = (0..n)
        .flat_map(|i| [vals[i], vals[(i + 1) % n], vals[(i + 2) % n]])
        .collect();
    // Names with XML metacharacters, non-ASCII letters and spaces.
    let names = ["rho", "a<\"b\">&'c", "µ ünï", " v "];
    let want: [&[f64]; 4] = [&vals, &ints_f, &padded(&vec2), &xyz];
    let origin = [1.0 / 3.0, -2.5e300, -5e-324];
    let spacing = [0.1, 1e-300, f64::MAX];
    for enc in [Encoding::Binary, Encoding::Ascii] {
        // Particles: positions and every kind of point array.
        let mut p = Particles::new(&xyz, 3).unwrap().encoding(enc);
        p.add_scalar(names[0], &vals)
            .unwrap()
            .add_scalar(names[1], &ints)
            .unwrap()
            .add_vector(names[2], &vec2, 2)
            .unwrap()
            .add_vector(names[3], &xyz, 3)
            .unwrap();
        let path = dir.join(format!("exact_{enc:?}.vtp"));
        p.write(&path).unwrap();
        let root = parse_xml(&std::fs::read_to_string(&path).unwrap());
        let hdr = header_type(&root);
        let piece = root.child("PolyData").child("Piece");
        assert_eq!(piece.attr("NumberOfPoints"), n.to_string());
        let points = piece.child("Points").arrays();
        assert_eq!(bits(&values(points[0], hdr)), bits(&xyz), "{enc:?} points");
        let pd = piece.child("PointData");
        if enc == Encoding::Ascii {
            // Shortest round-trip text, exponent form for tiny and huge magnitudes
            // (`1e-300`, not 300 zeros).
            let tokens: Vec<&str> = pd.arrays()[0].text.split_whitespace().collect();
            let exact: Vec<String> = vals.iter().map(|&v| numfmt::exact(v)).collect();
            assert_eq!(tokens, exact);
            assert!(tokens.contains(&"1e-300") && tokens.contains(&"-2.5e300"));
        }
        assert_eq!(pd.attr_text("Scalars"), names[0]);
        assert_eq!(pd.attr_text("Vectors"), names[2]);
        let arrays = pd.arrays();
        assert_eq!(arrays.len(), 4);
        for ((a, name), want) in arrays.iter().zip(names).zip(want) {
            assert_eq!(a.attr_text("Name"), name);
            assert_eq!(a.attr("type"), "Float64");
            let got = values(a, hdr);
            let comps: usize = a.attr("NumberOfComponents").parse().unwrap();
            assert_eq!(got.len(), comps * n, "{enc:?} {name}");
            assert_eq!(bits(&got), bits(want), "{enc:?} {name}: {got:?}");
        }

        // Image data: awkward origin and spacing, a scalar and a padded vector field.
        let mut g = ImageData::new([n, 1, 1], origin, spacing)
            .unwrap()
            .encoding(enc);
        g.add_scalar(names[1], &vals)
            .unwrap()
            .add_vector(names[0], &vec2, 2)
            .unwrap();
        let path = dir.join(format!("exact_{enc:?}.vti"));
        g.write(&path).unwrap();
        let root = parse_xml(&std::fs::read_to_string(&path).unwrap());
        let img = root.child("ImageData");
        assert_eq!(bits(&three(img.attr("Origin"))), bits(&origin));
        assert_eq!(bits(&three(img.attr("Spacing"))), bits(&spacing));
        let arrays = img.child("Piece").child("PointData").arrays();
        assert_eq!(arrays[0].attr_text("Name"), names[1]);
        assert_eq!(bits(&values(arrays[0], header_type(&root))), bits(&vals));
        assert_eq!(arrays[1].attr_text("Name"), names[0]);
        let got = values(arrays[1], header_type(&root));
        assert_eq!(bits(&got), bits(&padded(&vec2)), "{enc:?}");
    }
    // Binary keeps what text cannot: NaN payloads and infinities.
    let odd = [
        f64::from_bits(0x7ff8_0000_dead_beef),
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut p = Particles::new(&[0.0; 9], 3).unwrap();
    p.add_scalar("odd", &odd).unwrap();
    let root = parse_xml(&p.to_xml().unwrap());
    let pd = root.child("PolyData").child("Piece").child("PointData");
    assert_eq!(
        bits(&values(pd.arrays()[0], header_type(&root))),
        bits(&odd)
    );
    // Series: awkward times and file names.
    let entries = [
        (1.0 / 3.0, "a&b<c>.vtp"),
        (1e-300, "d\"e'.vti"),
        (-2.5e300, "µ.vtp"),
    ];
    write_pvd(dir.join("series.pvd"), &entries).unwrap();
    let root = parse_xml(&std::fs::read_to_string(dir.join("series.pvd")).unwrap());
    let sets = &root.child("Collection").children;
    assert_eq!(sets.len(), entries.len());
    for (set, (t, file)) in sets.iter().zip(entries) {
        let got: f64 = set.attr("timestep").parse().unwrap();
        assert_eq!(got.to_bits(), t.to_bits());
        assert_eq!(set.attr_text("file"), file);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// One extended XYZ frame as read back: the comment line's `key=value` pairs (quotes
/// removed) and one line of tokens per particle.
struct XyzRead {
    comment: Vec<(String, String)>,
    rows: Vec<Vec<String>>,
}

impl XyzRead {
    fn get(&self, key: &str) -> &str {
        let mut hits = self.comment.iter().filter(|(k, _)| k == key);
        let v = &hits.next().unwrap_or_else(|| panic!("no {key}")).1;
        assert!(hits.next().is_none(), "{key} twice");
        v
    }

    /// Column `name` of the `Properties` spec as text tokens, `width` per particle.
    fn column(&self, name: &str) -> (char, Vec<Vec<String>>) {
        let spec: Vec<&str> = self.get("Properties").split(':').collect();
        assert_eq!(spec.len() % 3, 0);
        let mut start = 0;
        for f in spec.chunks(3) {
            let width: usize = f[2].parse().unwrap();
            if f[0] == name {
                let kind = f[1].chars().next().unwrap();
                let cols = self.rows.iter().map(|r| r[start..start + width].to_vec());
                return (kind, cols.collect());
            }
            start += width;
        }
        panic!("no column {name}");
    }

    /// Real column `name` (type `R`), all particles' values in order.
    fn reals(&self, name: &str) -> Vec<f64> {
        let (kind, rows) = self.column(name);
        assert_eq!(kind, 'R', "{name}");
        rows.iter().flatten().map(|t| t.parse().unwrap()).collect()
    }
}

/// A small extended XYZ reader: count line, comment line, one line per particle.
fn parse_xyz(text: &str) -> Vec<XyzRead> {
    let mut lines = text.lines();
    let mut frames = Vec::new();
    while let Some(count) = lines.next() {
        let n: usize = count.parse().unwrap();
        let mut comment = Vec::new();
        let mut rest = lines.next().unwrap().trim();
        while !rest.is_empty() {
            let eq = rest.find('=').unwrap();
            let key = rest[..eq].to_string();
            let (value, tail) = match rest[eq + 1..].strip_prefix('"') {
                Some(q) => q.split_once('"').unwrap(),
                None => rest[eq + 1..]
                    .split_once(' ')
                    .unwrap_or((&rest[eq + 1..], "")),
            };
            comment.push((key, value.to_string()));
            rest = tail.trim_start();
        }
        let rows = (0..n)
            .map(|_| lines.next().unwrap().split(' ').map(String::from).collect())
            .collect();
        frames.push(XyzRead { comment, rows });
    }
    frames
}

#[test]
fn xyz_values_read_back_bit_for_bit() {
    let dir = tmp("xyz-exact");
    let vals = awkward();
    let n = vals.len();
    let ints = awkward_ints(n);
    let xyz: Vec<f64> = (0..n)
        .flat_map(|i| [vals[i], vals[(i + 1) % n], vals[(i + 2) % n]])
        .collect();
    let vec2: Vec<f64> = vals
        .iter()
        .zip(vals.iter().rev())
        .flat_map(|(&a, &b)| [a, b])
        .collect();
    let species: Vec<&str> = (0..n)
        .map(|i| ["H", "Ca", "Fe", "Og", "X"][i % 5])
        .collect();
    let lattice = [
        [1.0 / 3.0, 0.1, 1e-300],
        [-0.0, 2.5e300, 5e-324],
        [7.0, 0.2, 1e16],
    ];

    let mut f = XyzFrame::new(&xyz, 3).unwrap();
    f.species(&species)
        .unwrap()
        .lattice(lattice)
        .unwrap()
        .pbc([true, false, true])
        .time(1e-300)
        .unwrap()
        .info("energy", -2.5e300)
        .unwrap()
        .info("step", 12_345_678_901.0)
        .unwrap()
        .add_scalar("charge", &vals)
        .unwrap()
        .add_scalar("id", &ints)
        .unwrap()
        .add_vector("v", &vec2, 2)
        .unwrap()
        .add_vector("f", &xyz, 3)
        .unwrap();
    let pairs: Vec<[f64; 2]> = vec2.chunks(2).map(|c| [c[0], c[1]]).collect();
    let mut g = XyzFrame::from_xy(&pairs).unwrap();
    g.box_2d(1.0 / 3.0, 0.1).unwrap().time(2.0 / 3.0).unwrap();
    let path = dir.join("exact.xyz");
    write_xyz(&path, &[f, g]).unwrap();

    let frames = parse_xyz(&std::fs::read_to_string(&path).unwrap());
    assert_eq!(frames.len(), 2);
    let a = &frames[0];
    assert_eq!(a.rows.len(), n);
    assert_eq!(
        a.get("Properties"),
        "species:S:1:pos:R:3:charge:R:1:id:R:1:v:R:3:f:R:3"
    );
    let cell: Vec<f64> = a
        .get("Lattice")
        .split(' ')
        .map(|t| t.parse().unwrap())
        .collect();
    assert_eq!(bits(&cell), bits(lattice.as_flattened()));
    assert_eq!(a.get("pbc"), "T F T");
    for (key, want) in [
        ("Time", 1e-300f64),
        ("energy", -2.5e300),
        ("step", 12_345_678_901.0),
    ] {
        let got: f64 = a.get(key).parse().unwrap();
        assert_eq!(got.to_bits(), want.to_bits(), "{key}");
    }
    let (kind, names) = a.column("species");
    assert_eq!(kind, 'S');
    assert_eq!(names.concat(), species);
    assert_eq!(bits(&a.reals("pos")), bits(&xyz), "positions");
    assert_eq!(bits(&a.reals("charge")), bits(&vals), "charge");
    let ints_f: Vec<f64> = ints.iter().map(|&i| f64::from(i)).collect();
    assert_eq!(bits(&a.reals("id")), bits(&ints_f), "id");
    assert_eq!(bits(&a.reals("v")), bits(&padded(&vec2)), "v");
    assert_eq!(bits(&a.reals("f")), bits(&xyz), "f");

    // The 2D frame: z = +0, the default species, a 2D box.
    let b = &frames[1];
    assert_eq!(b.get("Properties"), "species:S:1:pos:R:3");
    assert_eq!(bits(&b.reals("pos")), bits(&padded(&vec2)));
    assert!(b.column("species").1.iter().all(|s| s == &["X"]));
    let cell: Vec<f64> = b
        .get("Lattice")
        .split(' ')
        .map(|t| t.parse().unwrap())
        .collect();
    assert_eq!(
        bits(&cell),
        bits(&[1.0 / 3.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 1.0])
    );
    assert_eq!(b.get("pbc"), "T T F");
    assert_eq!(
        b.get("Time").parse::<f64>().unwrap().to_bits(),
        (2.0f64 / 3.0).to_bits()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
