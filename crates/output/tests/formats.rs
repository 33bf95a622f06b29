//! VTK, extended XYZ and CSV files parse back with the right counts.

use std::collections::HashMap;
use std::path::PathBuf;

use simkit_output::csv::{CsvWriter, write_csv};
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

/// Values of a DataArray (binary or ascii) as f64.
fn values(a: &Elem) -> Vec<f64> {
    match a.attr("format") {
        "ascii" => a
            .text
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect(),
        "binary" => {
            let raw = b64_decode(&a.text);
            let n = u32::from_le_bytes(raw[..4].try_into().unwrap()) as usize;
            let data = &raw[4..];
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
                "UInt8" => data.iter().map(|&b| b as f64).collect(),
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
        assert_eq!(values(arrays[0]), rho);
        assert_eq!(arrays[1].attr("NumberOfComponents"), "3");
        let u = values(arrays[1]);
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
fn vtu_parses_back() {
    let dir = tmp("vtu");
    for enc in [Encoding::Binary, Encoding::Ascii] {
        let n = 5;
        let pos: Vec<f32> = (0..2 * n).map(|i| i as f32 * 0.25).collect();
        let mut p = Particles::new(&pos, 2).unwrap().encoding(enc);
        let radius: Vec<f64> = (0..n).map(|i| 0.1 + i as f64 * 0.01).collect();
        let species: Vec<u32> = (0..n as u32).map(|i| i % 2).collect();
        let vel: Vec<f64> = (0..3 * n).map(|i| -(i as f64)).collect();
        p.add_scalar("radius", &radius)
            .unwrap()
            .add_scalar("species", &species)
            .unwrap()
            .add_vector("velocity", &vel, 3)
            .unwrap();
        assert_eq!(p.len(), n);
        let path = dir.join(format!("particles_{enc:?}.vtu"));
        p.write(&path).unwrap();
        let root = parse_xml(&std::fs::read_to_string(&path).unwrap());
        check_header(&root, "UnstructuredGrid");
        let piece = root.child("UnstructuredGrid").child("Piece");
        assert_eq!(piece.attr("NumberOfPoints"), "5");
        assert_eq!(piece.attr("NumberOfCells"), "5");
        let points = piece.child("Points").arrays();
        assert_eq!(points.len(), 1);
        assert_eq!(points[0].attr("NumberOfComponents"), "3");
        let xyz = values(points[0]);
        assert_eq!(xyz.len(), 15);
        assert_eq!(&xyz[..6], &[0.0, 0.25, 0.0, 0.5, 0.75, 0.0]);
        let cells = piece.child("Cells").arrays();
        let by_name: HashMap<&str, Vec<f64>> =
            cells.iter().map(|a| (a.attr("Name"), values(a))).collect();
        assert_eq!(by_name["connectivity"], [0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(by_name["offsets"], [1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(by_name["types"], [1.0; 5]);
        let pd = piece.child("PointData");
        let arrays = pd.arrays();
        assert_eq!(arrays.len(), 3);
        for a in arrays {
            let comps: usize = a.attr("NumberOfComponents").parse().unwrap();
            assert_eq!(values(a).len(), comps * n, "{}", a.attr("Name"));
        }
        assert_eq!(values(pd.arrays()[1]), [0.0, 1.0, 0.0, 1.0, 0.0]);
    }
    // Empty particle sets are valid files.
    let p = Particles::from_xyz(&[]).unwrap();
    let root = parse_xml(&p.to_xml().unwrap());
    assert_eq!(
        root.child("UnstructuredGrid")
            .child("Piece")
            .attr("NumberOfPoints"),
        "0"
    );
    // Series file.
    write_pvd(
        dir.join("series.pvd"),
        &[(0.0, "particles_Binary.vtu"), (0.5, "particles_Ascii.vtu")],
    )
    .unwrap();
    let root = parse_xml(&std::fs::read_to_string(dir.join("series.pvd")).unwrap());
    check_header(&root, "Collection");
    assert_eq!(root.child("Collection").children.len(), 2);
    std::fs::remove_dir_all(&dir).unwrap();
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
        let names: Vec<&str> = (0..n).map(|i| if i % 2 == 0 { "A" } else { "B" }).collect();
        f.species(&names)
            .unwrap()
            .box_2d(10.0, 5.0)
            .unwrap()
            .time(step as f64 * 0.5)
            .unwrap();
        f.add_scalar("radius", &vec![0.5f32; n]).unwrap();
        f.add_vector("velocity", &vec![1.0; 2 * n], 2).unwrap();
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
            comment.contains("Properties=species:S:1:pos:R:3:radius:R:1:velocity:R:3"),
            "{comment}"
        );
        assert!(
            comment.contains(&format!("Time={}", frames as f64 * 0.5)),
            "{comment}"
        );
        assert!(comment.contains("pbc=\"T T F\""), "{comment}");
        for k in 0..n {
            let cols: Vec<&str> = lines.next().unwrap().split_whitespace().collect();
            assert_eq!(cols.len(), 1 + 3 + 1 + 3);
            assert_eq!(cols[0], if k % 2 == 0 { "A" } else { "B" });
            assert_eq!(cols[3], "0");
            assert!(cols[1..].iter().all(|c| c.parse::<f64>().is_ok()));
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
    assert!(g.species(&["A", "B"]).is_err());
    assert!(g.species(&["two words"]).is_err());
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
