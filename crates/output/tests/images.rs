//! PNG heat maps, vector fields, plots and GIF animations.

use std::path::PathBuf;

use image::AnimationDecoder;
use image::codecs::gif::GifDecoder;
use simkit_output::colormap::{Colormap, NAN_COLOR};
use simkit_output::gif::{GifWriter, write_gif};
use simkit_output::heatmap::{HeatmapOptions, render_heatmap, write_heatmap};
use simkit_output::plot::{Plot, Scale, Series};
use simkit_output::vector_field::{VectorFieldOptions, write_vector_field};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("simkit-output-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn heatmap_png_dimensions_and_colours() {
    let dir = tmp("heatmap");
    let (w, h) = (5usize, 3usize);
    // Row-major, row 0 at the bottom: min at (col 0, row 0), max at (col 4, row 2).
    let field: Vec<f64> = (0..w * h).map(|i| i as f64).collect();
    let path = dir.join("plain.png");
    let opts = HeatmapOptions::new().upscale(4).colorbar(false);
    let range = write_heatmap(&path, &field, w, h, &opts).unwrap();
    assert_eq!(range, (0.0, 14.0));
    let img = image::open(&path).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (20, 12));
    // Bottom-left block holds row 0, col 0 = min; top-right holds the max.
    assert_eq!(img.get_pixel(1, 11).0, Colormap::Viridis.map(0.0));
    assert_eq!(img.get_pixel(1, 11).0, [0x44, 0x01, 0x54]);
    assert_eq!(img.get_pixel(19, 0).0, [0xfd, 0xe7, 0x25]);

    // f32 data, title and colour bar: larger image, same field colours; NaN in magenta.
    let mut f32s: Vec<f32> = field.iter().map(|&v| v as f32).collect();
    f32s[7] = f32::NAN;
    let opts = HeatmapOptions::new().upscale(4).title("T = 1.5e-3");
    let path = dir.join("decorated.png");
    write_heatmap(&path, &f32s, w, h, &opts).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    assert!(img.width() > 20 && img.height() > 12);
    assert!(img.pixels().any(|p| p.0 == NAN_COLOR));
    assert!(img.pixels().any(|p| p.0 == [0xfd, 0xe7, 0x25]));

    // Fixed range clamps.
    let (img, r) = render_heatmap(
        &field,
        w,
        h,
        &HeatmapOptions::new().range(5.0, 6.0).colorbar(false),
    )
    .unwrap();
    assert_eq!(r, (5.0, 6.0));
    assert_eq!(img.get_pixel(0, 2).0, Colormap::Viridis.map(0.0));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn heatmap_rejects_bad_input() {
    let o = HeatmapOptions::new();
    let e = render_heatmap(&[1.0; 5], 2, 3, &o).unwrap_err().to_string();
    assert!(e.contains('5') && e.contains("2 * 3"), "{e}");
    assert!(render_heatmap::<f64>(&[], 0, 0, &o).is_err());
    assert!(render_heatmap(&[1.0; 4], 2, 2, &o.clone().range(0.0, f64::NAN)).is_err());
    assert!(render_heatmap(&[1.0; 4], 2, 2, &o.clone().range(1.0, 0.0)).is_err());
    assert!(render_heatmap(&[1.0; 4], 2, 2, &o.clone().upscale(0)).is_err());
    assert!(render_heatmap(&[f64::NAN; 4], 2, 2, &o).is_err());
    assert!(render_heatmap(&[1.0; 4], 2, 2, &o.clone().upscale(100_000)).is_err());
}

#[test]
fn heatmap_refuses_a_huge_text_scale_before_allocating() {
    let o = HeatmapOptions::new().title("T");
    // u32::MAX used to overflow the layout and abort on the image allocation.
    for scale in [u32::MAX, 1 << 20, 5000] {
        let e = render_heatmap(&[1.0; 4], 2, 2, &o.clone().text_scale(scale))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("text_scale: {scale}")) && e.contains("32768"),
            "{e}"
        );
    }
    let e = render_heatmap(
        &[1.0; 4],
        2,
        2,
        &o.clone().colorbar(false).text_scale(u32::MAX),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("text_scale"), "{e}");
    // A title too wide at the automatic scale names the title.
    let long = "x".repeat(10_000);
    let e = render_heatmap(&[1.0; 4], 2, 2, &HeatmapOptions::new().title(long))
        .unwrap_err()
        .to_string();
    assert!(e.contains("title: 10000 characters"), "{e}");
    // Within the limit it renders; without text the scale is unused.
    let (img, _) = render_heatmap(&[1.0; 4], 2, 2, &o.clone().text_scale(8)).unwrap();
    assert!(img.height() >= 8 * 8);
    let bare = HeatmapOptions::new().colorbar(false).text_scale(u32::MAX);
    let (img, _) = render_heatmap(&[1.0; 4], 2, 2, &bare).unwrap();
    assert_eq!(img.dimensions(), (2, 2));
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
    let opts = VectorFieldOptions::new()
        .arrow_spacing(4)
        .background(HeatmapOptions::new().upscale(8).title("vortex"));
    let (lo, hi) = write_vector_field(&path, &vx, &vy, w, h, &opts).unwrap();
    assert!(lo >= 0.0 && hi > 19.0);
    let img = image::open(&path).unwrap().to_rgb8();
    assert!(img.width() > 256 && img.height() > 192);
    // Arrows are drawn in black or white on the field.
    assert!(img.pixels().filter(|p| p.0 == [255, 255, 255]).count() > 100);
    assert!(write_vector_field(&path, &vx, &vy[1..], w, h, &opts).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn plot_writes_png() {
    let dir = tmp("plot");
    let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.1).collect();
    let r: Vec<f64> = t.iter().map(|t| (1.0 + t).sqrt()).collect();
    let path = dir.join("radius.png");
    Plot::new("radius vs time")
        .x_label("t")
        .y_label("R(t)")
        .series(Series::line("R", &t, &r))
        .series(Series::points("fit", &t[..10], &r[..10]).color([200, 0, 0]))
        .write(&path)
        .unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (800, 500));
    assert!(img.pixels().any(|p| p.0 == simkit_output::plot::PALETTE[0]));
    assert!(img.pixels().any(|p| p.0 == [200, 0, 0]));

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
        assert!(
            img.pixels().any(|p| p.0 == color),
            "{}: no data drawn",
            plot.title
        );
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
