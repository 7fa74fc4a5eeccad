//! Charts and the contact sheet of `vplgi sweep`, drawn with plotters into an RGB buffer (PNG,
//! encoded by vplgi-image) and into SVG, both written atomically.

use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::OnceLock;

/// PNG text needs a TrueType font; `make setup` installs DejaVu Sans (fonts-dejavu-core).
const FONT_PATHS: [&str; 2] =
    ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/dejavu/DejaVuSans.ttf"];

/// Registers the font plotters draws text with, once: `$VPLGI_FONT`, else DejaVu Sans.
pub fn ensure_font() -> Result<()> {
    static FONT: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let candidates: Vec<String> = std::env::var("VPLGI_FONT").ok().into_iter().chain(FONT_PATHS.iter().map(|s| s.to_string())).collect();
        let path = candidates.iter().find(|p| Path::new(p).is_file()).ok_or_else(|| {
            format!(
                "charts need a TrueType font: install fonts-dejavu-core (make setup does) or set VPLGI_FONT to a .ttf file (looked for {})",
                candidates.join(", ")
            )
        })?;
        let bytes = std::fs::read(path).map_err(|e| format!("cannot read the font {path}: {e}"))?;
        plotters::style::register_font("sans-serif", FontStyle::Normal, Box::leak(bytes.into_boxed_slice()))
            .map_err(|_| format!("{path} is not a usable TrueType font"))
    })
    .clone()
    .map_err(|e| anyhow!(e))
}

/// One bar of a stacked-bar chart: a configuration's stage times and its image error.
pub struct Bar {
    pub label: String,
    /// (stage, milliseconds), bottom to top.
    pub stages: Vec<(&'static str, f64)>,
    pub error: f64,
}

/// The stage colours, close to the paper's (clustering blue, visibility red, shading yellow).
fn stage_colour(stage: &str) -> RGBColor {
    match stage {
        "trace_vpls" => RGBColor(150, 150, 150),
        "shading_points" => RGBColor(200, 200, 200),
        "cluster" => RGBColor(60, 110, 200),
        "visibility" => RGBColor(210, 60, 50),
        _ => RGBColor(240, 190, 40),
    }
}

const ERROR_COLOUR: RGBColor = RGBColor(130, 40, 160);

fn draw_bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    x_desc: &str,
    bars: &[Bar],
    error_name: &str,
    reference_ms: Option<f64>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let n = bars.len();
    // Headroom above the bars and the error line keeps the legend (top middle) clear of both.
    let top = bars
        .iter()
        .map(|b| b.stages.iter().map(|s| s.1).sum::<f64>())
        .fold(reference_ms.unwrap_or(0.0), f64::max)
        .max(1e-3)
        * 1.45;
    let err_top = bars.iter().map(|b| b.error).fold(0.0, f64::max).max(1e-12) * 1.45;
    let x_range = -0.5f64..(n as f64 - 0.5);
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .right_y_label_area_size(80)
        .build_cartesian_2d(x_range.clone(), 0f64..top)
        .map_err(|e| anyhow!("{e}"))?
        .set_secondary_coord(x_range, 0f64..err_top);
    let labels: Vec<String> = bars.iter().map(|b| b.label.clone()).collect();
    let x_fmt = |x: &f64| {
        if (x - x.round()).abs() < 1e-6 && x.round() >= 0.0 {
            labels.get(x.round() as usize).cloned().unwrap_or_default()
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n.max(2))
        .x_label_formatter(&x_fmt)
        .x_desc(x_desc)
        .y_desc("time (ms)")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_secondary_axes()
        .y_desc(error_name)
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .label_style(("sans-serif", 15).into_font().color(&ERROR_COLOUR))
        .axis_desc_style(("sans-serif", 16).into_font().color(&ERROR_COLOUR))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    let stages: Vec<&'static str> =
        bars.first().map(|b| b.stages.iter().map(|s| s.0).collect()).unwrap_or_default();
    for (k, stage) in stages.iter().enumerate() {
        let colour = stage_colour(stage);
        let rects: Vec<Rectangle<(f64, f64)>> = bars
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let below: f64 = b.stages[..k].iter().map(|s| s.1).sum();
                Rectangle::new(
                    [(i as f64 - 0.35, below), (i as f64 + 0.35, below + b.stages[k].1)],
                    colour.filled(),
                )
            })
            .collect();
        chart
            .draw_series(rects)
            .map_err(|e| anyhow!("{e}"))?
            .label(*stage)
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], colour.filled()));
    }
    if let Some(r) = reference_ms {
        chart
            .draw_series(LineSeries::new([(-0.5, r), (n as f64 - 0.5, r)], BLACK.stroke_width(1)))
            .map_err(|e| anyhow!("{e}"))?
            .label(format!("reference: {:.0} ms", r))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], BLACK));
    }
    let points: Vec<(f64, f64)> =
        bars.iter().enumerate().map(|(i, b)| (i as f64, b.error)).collect();
    chart
        .draw_secondary_series(LineSeries::new(points.clone(), ERROR_COLOUR.stroke_width(3)))
        .map_err(|e| anyhow!("{e}"))?
        .label(error_name)
        .legend(|(x, y)| PathElement::new([(x, y), (x + 14, y)], ERROR_COLOUR.stroke_width(3)));
    chart
        .draw_secondary_series(points.iter().map(|&p| Circle::new(p, 5, ERROR_COLOUR.filled())))
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperMiddle)
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// Time split by stage (stacked bars, left axis) and image error (line, right axis) per
/// configuration, the layout of the paper's Figures 7 and 9: `stem.png` and `stem.svg`.
pub fn stacked_bars(
    stem: &Path,
    title: &str,
    x_desc: &str,
    bars: &[Bar],
    error_name: &str,
    reference_ms: Option<f64>,
) -> Result<()> {
    ensure_font()?;
    let size = (960u32, 560u32);
    let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw_bars(&root, title, x_desc, bars, error_name, reference_ms)?;
    }
    write_png(stem, size, &rgb)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw_bars(&root, title, x_desc, bars, error_name, reference_ms)?;
    }
    write_text(&stem.with_extension("svg"), &svg)
}

/// One variant's line of [`variant_lines`]: its image error and frame time at each count.
pub struct Series {
    pub name: String,
    pub error: Vec<f64>,
    pub time_ms: Vec<f64>,
}

/// Distinct line colours, one per variant (colour-blind-safe Okabe-Ito order).
const SERIES_COLOURS: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

/// One panel of [`variant_lines`]: each series' error against `x(series, i)`.
fn draw_lines<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    x_desc: &str,
    error_name: &str,
    series: &[Series],
    x: &dyn Fn(&Series, usize) -> f64,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let xs = || series.iter().flat_map(|s| (0..s.error.len()).map(move |i| x(s, i)));
    let x_max = xs().fold(0.0, f64::max).max(1e-3) * 1.05;
    let x_min = xs().fold(f64::INFINITY, f64::min).min(x_max) * 0.95;
    let y_max =
        series.iter().flat_map(|s| s.error.iter().copied()).fold(0.0, f64::max).max(1e-12) * 1.35;
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(72)
        .build_cartesian_2d(x_min..x_max, 0f64..y_max)
        .map_err(|e| anyhow!("{e}"))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(error_name)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 15))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    for (j, s) in series.iter().enumerate() {
        let colour = SERIES_COLOURS[j % SERIES_COLOURS.len()];
        let points: Vec<(f64, f64)> = (0..s.error.len()).map(|i| (x(s, i), s.error[i])).collect();
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
            .map_err(|e| anyhow!("{e}"))?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 14, y)], colour.stroke_width(2)));
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
            .map_err(|e| anyhow!("{e}"))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

fn draw_variant_lines<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    counts: &[u32],
    count_desc: &str,
    series: &[Series],
    error_name: &str,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(|e| anyhow!("{e}"))?;
    let (w, _) = root.dim_in_pixel();
    let (left, right) = root.split_horizontally(w / 2);
    draw_lines(
        &left,
        "at equal time (lower left is better)",
        "frame time (ms)",
        error_name,
        series,
        &|s, i| s.time_ms[i],
    )?;
    draw_lines(&right, "at equal cluster count", count_desc, error_name, series, &|_, i| {
        counts[i] as f64
    })?;
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// Variants of a stage side by side: each variant's image error against its frame time (left:
/// which is better at equal time) and against the cluster count (right), one line per variant
/// through `counts`: `stem.png` and `stem.svg`.
pub fn variant_lines(
    stem: &Path,
    title: &str,
    counts: &[u32],
    count_desc: &str,
    series: &[Series],
    error_name: &str,
) -> Result<()> {
    ensure_font()?;
    let size = (1200u32, 540u32);
    let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw_variant_lines(&root, title, counts, count_desc, series, error_name)?;
    }
    write_png(stem, size, &rgb)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw_variant_lines(&root, title, counts, count_desc, series, error_name)?;
    }
    write_text(&stem.with_extension("svg"), &svg)
}

fn draw_heatmap<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    vpl: &[u32],
    sp: &[u32],
    time_ms: &[Vec<f64>],
    error: &[Vec<f64>],
    error_name: &str,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let (w, _) = root.dim_in_pixel();
    let (main, bar) = root.split_horizontally(w - 130);
    let all: Vec<f64> =
        error.iter().flatten().copied().filter(|e| e.is_finite() && *e > 0.0).collect();
    let (lo, hi) = (
        all.iter().copied().fold(f64::INFINITY, f64::min),
        all.iter().copied().fold(0.0, f64::max),
    );
    let (lo, hi) = if lo.is_finite() && hi > lo { (lo.log10(), hi.log10()) } else { (-6.0, 0.0) };
    // Log-scaled error to a colour: low error dark, high error bright.
    let colour = |e: f64| -> RGBColor {
        let t =
            if e > 0.0 { ((e.log10() - lo) / (hi - lo).max(1e-9)).clamp(0.0, 1.0) } else { 0.0 };
        ViridisRGB::get_color(t as f32)
    };
    let mut chart = ChartBuilder::on(&main)
        .caption(title, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(-0.5f64..(vpl.len() as f64 - 0.5), -0.5f64..(sp.len() as f64 - 0.5))
        .map_err(|e| anyhow!("{e}"))?;
    let fmt = |v: &[u32], x: &f64| {
        if (x - x.round()).abs() < 1e-6 && x.round() >= 0.0 {
            v.get(x.round() as usize).map_or(String::new(), |c| c.to_string())
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .disable_mesh()
        .x_labels(vpl.len().max(2))
        .y_labels(sp.len().max(2))
        .x_label_formatter(&|x| fmt(vpl, x))
        .y_label_formatter(&|y| fmt(sp, y))
        .x_desc("VPL clusters")
        .y_desc("shading-point clusters")
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 16))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    for (j, row) in error.iter().enumerate() {
        for (i, &e) in row.iter().enumerate() {
            let (x, y) = (i as f64, j as f64);
            chart
                .draw_series([Rectangle::new(
                    [(x - 0.5, y - 0.5), (x + 0.5, y + 0.5)],
                    colour(e).filled(),
                )])
                .map_err(|e| anyhow!("{e}"))?;
            let t = colour(e);
            let ink = if (t.0 as u32 + t.1 as u32 + t.2 as u32) > 380 { BLACK } else { WHITE };
            let style = ("sans-serif", 15)
                .into_font()
                .color(&ink)
                .pos(Pos::new(HPos::Center, VPos::Center));
            chart
                .draw_series([Text::new(
                    format!("{:.0} ms", time_ms[j][i]),
                    (x, y + 0.12),
                    style.clone(),
                )])
                .map_err(|e| anyhow!("{e}"))?;
            chart
                .draw_series([Text::new(format!("{e:.1e}"), (x, y - 0.18), style)])
                .map_err(|e| anyhow!("{e}"))?;
        }
    }
    // The colour bar of the error.
    let mut cb = ChartBuilder::on(&bar)
        .margin_top(52)
        .margin_bottom(60)
        .margin_right(12)
        .y_label_area_size(70)
        .build_cartesian_2d(0f64..1f64, lo..hi)
        .map_err(|e| anyhow!("{e}"))?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(5)
        .y_label_formatter(&|v| format!("{:.1e}", 10f64.powf(*v)))
        .y_desc(error_name)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .draw()
        .map_err(|e| anyhow!("{e}"))?;
    let steps = 64;
    cb.draw_series((0..steps).map(|k| {
        let (a, b) = (
            lo + (hi - lo) * k as f64 / steps as f64,
            lo + (hi - lo) * (k + 1) as f64 / steps as f64,
        );
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            ViridisRGB::get_color(k as f32 / (steps - 1) as f32).filled(),
        )
    }))
    .map_err(|e| anyhow!("{e}"))?;
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}

/// Time and error over both cluster counts (the paper's Figure 11): one cell per configuration,
/// coloured by the image error (log scale), labelled with the frame time and the error.
pub fn heatmap(
    stem: &Path,
    title: &str,
    vpl: &[u32],
    sp: &[u32],
    time_ms: &[Vec<f64>],
    error: &[Vec<f64>],
    error_name: &str,
) -> Result<()> {
    ensure_font()?;
    let size = (200 + 130 * vpl.len() as u32 + 130, 150 + 70 * sp.len() as u32);
    let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw_heatmap(&root, title, vpl, sp, time_ms, error, error_name)?;
    }
    write_png(stem, size, &rgb)?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw_heatmap(&root, title, vpl, sp, time_ms, error, error_name)?;
    }
    write_text(&stem.with_extension("svg"), &svg)
}

/// One tile of the contact sheet: a label over a tonemapped image and its error map (8-bit RGB
/// rows of the same size).
pub struct Tile {
    pub label: String,
    pub width: u32,
    pub height: u32,
    pub image: Vec<u8>,
    pub error_map: Vec<u8>,
}

/// Every configuration's image beside its error map, `columns` tiles per row, each picture
/// scaled to `thumb` pixels wide: one PNG.
pub fn contact_sheet(path: &Path, tiles: &[Tile], columns: usize, thumb: u32) -> Result<()> {
    ensure_font()?;
    let Some(first) = tiles.first() else {
        return Ok(());
    };
    let th = (thumb as u64 * first.height as u64 / first.width.max(1) as u64).max(1) as u32;
    let (gap, label_h) = (8u32, 24u32);
    let tile_w = 2 * thumb + gap;
    let tile_h = label_h + th;
    let cols = columns.clamp(1, tiles.len()) as u32;
    let rows = tiles.len().div_ceil(cols as usize) as u32;
    let size = (gap + cols * (tile_w + 2 * gap), gap + rows * (tile_h + gap));
    let mut rgb = vec![255u8; (size.0 * size.1 * 3) as usize];
    // Pictures first (box-filtered down to the thumbnail), then the labels on top.
    let mut origins = Vec::new();
    for (k, t) in tiles.iter().enumerate() {
        let (c, r) = (k as u32 % cols, k as u32 / cols);
        let (x0, y0) = (gap + c * (tile_w + 2 * gap), gap + r * (tile_h + gap));
        origins.push((x0, y0));
        for (pic, dx) in [(&t.image, 0), (&t.error_map, thumb + gap)] {
            blit_scaled(
                &mut rgb,
                size.0,
                (x0 + dx, y0 + label_h),
                (thumb, th),
                pic,
                (t.width, t.height),
            );
        }
    }
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        let style = ("sans-serif", 15).into_font().color(&BLACK);
        for (t, &(x0, y0)) in tiles.iter().zip(&origins) {
            root.draw(&Text::new(t.label.clone(), (x0 as i32, y0 as i32 + 4), style.clone()))
                .map_err(|e| anyhow!("{e}"))?;
        }
        root.present().map_err(|e| anyhow!("{e}"))?;
    }
    write_png(path, size, &rgb)
}

/// Box-filters `src` (w x h RGB) into the `dst` rectangle at `at` of size `to`.
fn blit_scaled(
    dst: &mut [u8],
    dst_w: u32,
    at: (u32, u32),
    to: (u32, u32),
    src: &[u8],
    size: (u32, u32),
) {
    let scaled = vplgi_image::resize_rgb8(src, size, to);
    for y in 0..to.1 {
        let o = (((at.1 + y) * dst_w + at.0) * 3) as usize;
        let row = (y * to.0 * 3) as usize;
        dst[o..o + (to.0 * 3) as usize].copy_from_slice(&scaled[row..row + (to.0 * 3) as usize]);
    }
}

fn write_png(stem: &Path, (w, h): (u32, u32), rgb: &[u8]) -> Result<()> {
    let path = stem.with_extension("png");
    vplgi_image::write_rgb8_png(&path, w, h, rgb)
        .with_context(|| format!("writing {}", path.display()))
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    vplgi_image::write_atomically(path, |w| {
        use std::io::Write;
        w.write_all(text.as_bytes())
    })
    .with_context(|| format!("writing {}", path.display()))
}
