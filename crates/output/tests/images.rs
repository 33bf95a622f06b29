//! Figures (heat maps, vector fields, particle frames, plots; PNG and SVG) and GIF
//! animations. The checks are on properties (sizes, colours present, text in the SVG,
//! errors), never on pixel-exact font rendering.

use std::path::PathBuf;

use image::codecs::gif::GifDecoder;
use image::{AnimationDecoder, RgbImage};
use simkit_output::colormap::{Colormap, NAN_COLOR};
use simkit_output::gif::{GifWriter, write_gif};
use simkit_output::heatmap::{HeatmapOptions, render_heatmap, write_heatmap};
use simkit_output::particles::ParticleFrame;
use simkit_output::plot::{Plot, Scale, Series};
use simkit_output::vector_field::{VectorFieldOptions, write_vector_field};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("simkit-output-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The text elements of an SVG file, trimmed.
fn svg_texts(path: &std::path::Path) -> Vec<String> {
    let svg = std::fs::read_to_string(path).unwrap();
    assert!(svg.starts_with("<svg"), "{}", &svg[..40.min(svg.len())]);
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = &t[t.find('>')? + 1..t.find("</text>")?];
            Some(body.trim().to_string())
        })
        .collect()
}

fn has(img: &RgbImage, c: [u8; 3]) -> bool {
    img.pixels().any(|p| p.0 == c)
}

/// Columns holding non-white pixels in rows `rows` (the extent of text there).
fn ink_columns(img: &RgbImage, rows: std::ops::Range<u32>) -> Option<(u32, u32)> {
    let mut span: Option<(u32, u32)> = None;
    for y in rows {
        for x in 0..img.width() {
            if img.get_pixel(x, y).0 != [255, 255, 255] {
                span = Some(span.map_or((x, x), |(a, b)| (a.min(x), b.max(x))));
            }
        }
    }
    span
}

#[test]
fn heatmap_png_field_colours_and_colour_bar() {
    let dir = tmp("heatmap");
    let (w, h) = (5usize, 3usize);
    let field: Vec<f64> = (0..w * h).map(|i| i as f64).collect();
    let path = dir.join("plain.png");
    let opts = HeatmapOptions::new().upscale(4).colorbar(false);
    let range = write_heatmap(&path, &field, w, h, &opts).unwrap();
    assert_eq!(range, (0.0, 14.0));
    let img = image::open(&path).unwrap().to_rgb8();
    // The field is enlarged to 320 pixels across, plus axes: wider and taller than it.
    assert!(
        img.width() > 320 && img.height() > 192,
        "{:?}",
        img.dimensions()
    );
    assert!(has(&img, Colormap::Viridis.map(0.0)) && has(&img, Colormap::Viridis.map(1.0)));

    // A constant field in the middle of a fixed range: only the colour bar shows the ends.
    let flat = vec![0.5; w * h];
    let mid = HeatmapOptions::new().range(0.0, 1.0);
    let (bare, _) = render_heatmap(&flat, w, h, &mid.clone().colorbar(false)).unwrap();
    let (with_bar, _) = render_heatmap(&flat, w, h, &mid.quantity("u (concentration)")).unwrap();
    for end in [0.0, 1.0] {
        let c = Colormap::Viridis.map(end);
        assert!(!has(&bare, c) && has(&with_bar, c), "end {end}");
    }
    assert!(with_bar.width() > bare.width());

    // NaN cells in magenta.
    let mut f32s: Vec<f32> = field.iter().map(|&v| v as f32).collect();
    f32s[7] = f32::NAN;
    let (img, _) = render_heatmap(&f32s, w, h, &HeatmapOptions::new()).unwrap();
    assert!(has(&img, NAN_COLOR));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn heatmap_svg_has_titles_axes_and_quantity() {
    let dir = tmp("heatmap-svg");
    let (w, h) = (40, 20);
    // Minimum a hair below zero: the colour bar must read 0, not -2.26e-50.
    let mut field: Vec<f64> = (0..w * h).map(|i| (i % w) as f64 / 52.0).collect();
    field[0] = -2.26e-50;
    let opts = HeatmapOptions::new()
        .upscale(8)
        .extent(0.0, 2.0, 0.0, 1.0)
        .x_label("x (mm)")
        .y_label("y (mm)")
        .quantity("ρ (g/cm³)")
        .title("density of the mixture")
        .subtitle("t = 0.25 s, ω = 3");
    let path = dir.join("rho.svg");
    write_heatmap(&path, &field, w, h, &opts).unwrap();
    let texts = svg_texts(&path);
    for text in [
        "density of the mixture",
        "t = 0.25 s, ω = 3",
        "x (mm)",
        "y (mm)",
        "ρ (g/cm³)",
        "0.5",
        "0",
    ] {
        assert!(
            texts.iter().any(|t| t == text),
            "missing {text} in {texts:?}"
        );
    }
    assert!(!texts.iter().any(|t| t.contains("e-50")), "{texts:?}");
    // The same options as PNG; an unknown extension is refused with the fix.
    write_heatmap(dir.join("rho.png"), &field, w, h, &opts).unwrap();
    let e = write_heatmap(dir.join("rho.jpg"), &field, w, h, &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("rho.jpg") && e.contains(".svg"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn long_titles_fit_the_image() {
    let title = "Gray-Scott pattern, F = 0.0367, k = 0.0649, 256 x 256, t = 10000 (ω τ)";
    assert!(title.chars().count() > 60);
    let (img, _) = render_heatmap(
        &[0.0, 1.0, 2.0, 3.0],
        2,
        2,
        &HeatmapOptions::new().title(title),
    )
    .unwrap();
    let (left, right) = ink_columns(&img, 0..30).expect("title drawn");
    assert!(
        left > 0 && right < img.width() - 1,
        "{left}..{right} of {}",
        img.width()
    );
    let plot = Plot::new(title)
        .size(400, 300)
        .series(Series::line("a", &[0.0, 1.0], &[0.0, 1.0]))
        .render()
        .unwrap();
    let (left, right) = ink_columns(&plot, 0..30).expect("title drawn");
    assert!(left > 0 && right < 399, "{left}..{right}");
}

#[test]
fn heatmap_rejects_bad_input() {
    let o = HeatmapOptions::new();
    let e = render_heatmap(&[1.0; 5], 2, 3, &o).unwrap_err().to_string();
    assert!(e.contains("data.len()") && e.contains("2 * 3"), "{e}");
    let e = render_heatmap::<f64>(&[], 0, 0, &o)
        .unwrap_err()
        .to_string();
    assert!(e.contains("grid size"), "{e}");
    let e = render_heatmap(&[f64::NAN, f64::INFINITY], 2, 1, &o)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no finite value"), "{e}");
    assert!(render_heatmap(&[1.0; 4], 2, 2, &o.clone().range(0.0, f64::NAN)).is_err());
    assert!(render_heatmap(&[1.0; 4], 2, 2, &o.clone().range(1.0, 0.0)).is_err());
    assert!(render_heatmap(&[1.0; 4], 2, 2, &o.clone().upscale(0)).is_err());
    let e = render_heatmap(&[1.0; 4], 2, 2, &o.clone().upscale(100_000))
        .unwrap_err()
        .to_string();
    assert!(e.contains("upscale"), "{e}");
    let e = render_heatmap(&[1.0; 4], 2, 2, &o.extent(0.0, f64::NAN, 0.0, 1.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("extent x"), "{e}");
}

#[test]
fn vector_field_png() {
    let dir = tmp("vector");
    let (w, h) = (32, 24);
    let mut vx = vec![0.0; w * h];
    let mut vy = vec![0.0; w * h];
    for j in 0..h {
        for i in 0..w {
            let (x, y) = (i as f64 - 16.0, j as f64 - 12.0);
            vx[j * w + i] = -y;
            vy[j * w + i] = x;
        }
    }
    let path = dir.join("vortex.png");
    let opts = VectorFieldOptions::new().arrow_spacing(4).background(
        HeatmapOptions::new()
            .upscale(8)
            .title("vortex")
            .quantity("|u| (cells/step)"),
    );
    let (lo, hi) = write_vector_field(&path, &vx, &vy, w, h, &opts).unwrap();
    assert!(lo >= 0.0 && hi > 19.0);
    let img = image::open(&path).unwrap().to_rgb8();
    assert!(img.width() > 256 && img.height() > 192);
    // Arrows are drawn in black or white on the field: white pixels inside the field.
    let field_white = (100..300)
        .flat_map(|x| (60..200).map(move |y| (x, y)))
        .filter(|&(x, y)| img.get_pixel(x, y).0 == [255, 255, 255])
        .count();
    assert!(field_white > 50, "{field_white}");
    let svg = dir.join("vortex.svg");
    write_vector_field(&svg, &vx, &vy, w, h, &opts).unwrap();
    assert!(svg_texts(&svg).iter().any(|t| t == "|u| (cells/step)"));
    assert!(write_vector_field(&path, &vx, &vy[1..], w, h, &opts).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn particle_frames_by_value_and_species() {
    let dir = tmp("particles");
    let pos: Vec<[f64; 2]> = (0..40)
        .map(|i| [0.5 + (i % 8) as f64, 0.5 + (i / 8) as f64])
        .collect();
    let radii = vec![0.45; 40];
    let speed: Vec<f64> = (0..40).map(|i| i as f64 * 0.01).collect();
    let frame = ParticleFrame::new(&pos, &radii)
        .bounds(0.0, 8.0, 0.0, 5.0)
        .by_value(&speed, "|v| (d/τ)")
        .title("bed")
        .subtitle("t = 2.5 τ")
        .x_label("x (d)")
        .y_label("z (d)");
    let img = frame.render().unwrap();
    assert!(has(&img, Colormap::Viridis.map(0.0)) && has(&img, Colormap::Viridis.map(1.0)));
    frame.write(dir.join("bed.svg")).unwrap();
    let texts = svg_texts(&dir.join("bed.svg"));
    for text in ["|v| (d/τ)", "t = 2.5 τ", "x (d)", "z (d)"] {
        assert!(
            texts.iter().any(|t| t == text),
            "missing {text} in {texts:?}"
        );
    }
    let svg = std::fs::read_to_string(dir.join("bed.svg")).unwrap();
    assert!(svg.matches("<circle").count() >= 40);
    let ids: Vec<usize> = (0..40).map(|i| i % 2).collect();
    let species = ParticleFrame::new(&pos, &radii)
        .by_species(&ids, &["small", "large"])
        .species_colors(&[[230, 120, 20], [30, 90, 200]])
        .circle((4.0, 2.5), 4.5);
    let img = species.render().unwrap();
    assert!(has(&img, [230, 120, 20]) && has(&img, [30, 90, 200]));
    species.write(dir.join("species.svg")).unwrap();
    let texts = svg_texts(&dir.join("species.svg"));
    assert!(texts.iter().any(|t| t == "small") && texts.iter().any(|t| t == "large"));

    let e = ParticleFrame::new(&pos, &radii)
        .by_species(&ids, &["only"])
        .render()
        .unwrap_err()
        .to_string();
    assert!(e.contains("species id[1]"), "{e}");
    let mut bad = pos.clone();
    bad[3][1] = f64::NAN;
    let e = ParticleFrame::new(&bad, &radii)
        .render()
        .unwrap_err()
        .to_string();
    assert!(e.contains("position[3]"), "{e}");
    let e = ParticleFrame::new(&pos, &radii[1..])
        .render()
        .unwrap_err()
        .to_string();
    assert!(e.contains("radii.len()"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn plot_writes_png_and_svg() {
    let dir = tmp("plot");
    let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.1).collect();
    let r: Vec<f64> = t.iter().map(|t| (1.0 + t).sqrt()).collect();
    let plot = Plot::new("radius vs time")
        .x_label("t (ω⁻¹)")
        .y_label("R(t) (σ)")
        .series(Series::line("R", &t, &r))
        .series(Series::points("fit", &t[..10], &r[..10]).color([200, 0, 0]));
    plot.write(dir.join("radius.png")).unwrap();
    let img = image::open(dir.join("radius.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (800, 500));
    assert!(has(&img, simkit_output::plot::PALETTE[0]));
    assert!(has(&img, [200, 0, 0]));
    plot.write(dir.join("radius.svg")).unwrap();
    let texts = svg_texts(&dir.join("radius.svg"));
    for text in ["radius vs time", "t (ω⁻¹)", "R(t) (σ)", "fit", "R"] {
        assert!(
            texts.iter().any(|t| t == text),
            "missing {text} in {texts:?}"
        );
    }

    let h = [0.1, 0.05, 0.025, 0.0125, 0.00625];
    let e: Vec<f64> = h.iter().map(|h| 3.0 * h * h).collect();
    let img = Plot::new("convergence")
        .size(640, 480)
        .x_scale(Scale::Log10)
        .y_scale(Scale::Log10)
        .series(Series::line("err", &h, &e))
        .render()
        .unwrap();
    assert_eq!(img.dimensions(), (640, 480));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn plot_rejects_bad_input() {
    let msg = |p: Plot| p.render().unwrap_err().to_string();
    assert!(msg(Plot::new("empty")).contains("at least one series"));
    let e = msg(Plot::new("x").series(Series::line::<f64, f64>("none", &[], &[])));
    assert!(e.contains("'none'") && e.contains("0 points"), "{e}");
    let e = msg(Plot::new("x").series(Series::line("len", &[1.0, 2.0], &[1.0])));
    assert!(e.contains("same length"), "{e}");
    let e = msg(Plot::new("x").y_scale(Scale::Log10).series(Series::line(
        "err",
        &[1.0, 2.0, 3.0],
        &[1e-3, 0.0, 1e-5],
    )));
    assert!(
        e.contains("'err'") && e.contains("y[1]") && e.contains("log10"),
        "{e}"
    );
    let e = msg(Plot::new("x").series(Series::line("nan", &[1.0, f64::NAN], &[1.0, 2.0])));
    assert!(e.contains("x[1]") && e.contains("NaN"), "{e}");
    let ok = Series::line("a", &[1.0, 2.0], &[1.0, 2.0]);
    assert!(
        Plot::new("x")
            .series(ok.clone())
            .size(10, 10)
            .render()
            .is_err()
    );
    assert!(
        Plot::new("x")
            .series(ok.clone())
            .x_range(2.0, 1.0)
            .render()
            .is_err()
    );
    assert!(
        Plot::new("x")
            .series(ok)
            .x_scale(Scale::Log10)
            .x_range(0.0, 1.0)
            .render()
            .is_err()
    );
}

#[test]
fn plot_handles_values_near_f64_max() {
    // y from -1e308 to 1e308 used to panic with "capacity overflow" in the tick computation.
    let x = [0.0, 1.0, 2.0];
    let color = [200, 0, 0];
    let cases = [
        Plot::new("huge").series(Series::line("y", &x, &[-1e308, 0.0, 1e308]).color(color)),
        Plot::new("max").series(Series::line("y", &x, &[f64::MIN, 1.0, f64::MAX]).color(color)),
        Plot::new("x").series(Series::line("y", &[-1e308, 1e308], &[1.0, 2.0]).color(color)),
        Plot::new("flat").series(Series::line("y", &x, &[1.7e308; 3]).color(color)),
        Plot::new("fixed")
            .y_range(f64::MIN, f64::MAX)
            .series(Series::line("y", &x, &[-1.0, 0.0, 1.0]).color(color)),
        Plot::new("log")
            .y_scale(Scale::Log10)
            .series(Series::line("y", &x, &[1e308, 1.5e308, f64::MAX]).color(color)),
    ];
    for plot in cases {
        let img = plot
            .render()
            .unwrap_or_else(|e| panic!("{}: {e}", plot.title));
        assert!(has(&img, color), "{}: no data drawn", plot.title);
    }
}

#[test]
fn gif_has_all_frames() {
    let dir = tmp("gif");
    let (w, h) = (16, 12);
    let opts = HeatmapOptions::new().range(-1.0, 1.0).upscale(3);
    let frames: Vec<_> = (0..7)
        .map(|k| {
            let f: Vec<f64> = (0..w * h)
                .map(|i| ((i + 3 * k) as f64 * 0.2).sin())
                .collect();
            render_heatmap(&f, w, h, &opts).unwrap().0
        })
        .collect();
    let path = dir.join("anim.gif");
    write_gif(&path, &frames, 80).unwrap();
    let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
    let decoded = GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap();
    assert_eq!(decoded.len(), 7);
    assert_eq!(decoded[0].buffer().dimensions(), frames[0].dimensions());
    assert_eq!(decoded[0].delay().numer_denom_ms(), (80, 1));

    // Streaming writer; size mismatch rejected; unfinished writer leaves no file.
    let mut g = GifWriter::create(dir.join("stream.gif"), 50).unwrap();
    g.push(&frames[0]).unwrap();
    assert!(g.push(&image::RgbImage::new(3, 3)).is_err());
    g.push(&frames[1]).unwrap();
    g.finish().unwrap();
    let file = std::io::BufReader::new(std::fs::File::open(dir.join("stream.gif")).unwrap());
    assert_eq!(GifDecoder::new(file).unwrap().into_frames().count(), 2);
    let mut g = GifWriter::create(dir.join("dropped.gif"), 50).unwrap();
    g.push(&frames[0]).unwrap();
    drop(g);
    assert!(!dir.join("dropped.gif").exists());
    assert!(write_gif(dir.join("none.gif"), &[], 10).is_err());
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert_eq!(names, ["anim.gif", "stream.gif"]);
    std::fs::remove_dir_all(&dir).unwrap();
}
