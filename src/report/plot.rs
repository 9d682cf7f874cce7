//! Plots of navigation error (crate `plotters`): SVG for the HTML report and
//! PNG files, with the bundled DejaVu Sans font so no system font library is
//! needed.

use crate::error::{Error, Result};
use plotters::prelude::*;
use std::sync::Once;

const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font is compiled in; failing to parse it would be a build defect.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES);
    });
}

/// One error series against time or distance.
#[derive(Debug, Clone, Default)]
pub struct ErrorSeries {
    /// Abscissa: time (s) or distance (m).
    pub x: Vec<f64>,
    /// Horizontal error (m).
    pub error: Vec<f64>,
    /// The filter's 95 % horizontal bound (m), where known.
    pub bound95: Vec<Option<f64>>,
    /// Monte Carlo envelope on its own abscissae: x, then median, 95th
    /// percentile and maximum over runs (m).
    pub envelope: Option<(Vec<f64>, [Vec<f64>; 3])>,
}

/// What came of a pass by a tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassKind {
    /// Read, and the filter accepted the fix.
    Accepted,
    /// Read, but the filter's gate rejected the fix.
    Rejected,
    /// Not read (or read after the run ended).
    Missed,
}

/// A tag pass to mark: its abscissa and what came of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TagMark {
    /// Time (s) or distance (m), as the plot's x axis.
    pub x: f64,
    /// Read and accepted, rejected, or missed.
    pub kind: PassKind,
}

/// What to draw besides the series.
#[derive(Debug, Clone, Default)]
pub struct PlotDecor {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Requirement line (m).
    pub requirement_m: Option<f64>,
    /// Tag passes (ticks at the bottom: accepted reads purple and tall,
    /// rejected reads red, missed passes grey and short).
    pub tag_passes: Vec<TagMark>,
    /// Abscissa intervals to shade (odometer faults).
    pub shaded: Vec<(f64, f64)>,
    /// Legend of the main series (default "horizontal error (run 0)").
    pub error_label: Option<String>,
    /// Legend of the bound series (default "filter 95 % bound").
    pub bound_label: Option<String>,
    /// Label of the y axis (default "horizontal error (m)").
    pub y_label: Option<String>,
    /// Top of the y axis (m); series above it are clipped to it.
    pub y_max: Option<f64>,
    /// Legend of accepted tag reads (default "tag read").
    pub tag_label: Option<String>,
    /// Unit of the y axis where it is not metres (e.g. "%", "°"): the
    /// clipped curve's maximum is then given to three significant digits
    /// in it.
    pub y_unit: Option<String>,
}

/// Tag passes as ticks on a time (`by_time`) or distance axis.
pub(super) fn tag_marks(passes: &[super::PassRow], by_time: bool) -> Vec<TagMark> {
    passes
        .iter()
        .map(|p| TagMark {
            x: if by_time { p.t_s } else { p.distance_m },
            kind: p.kind,
        })
        .collect()
}

/// Odometer faults ((from, to) in time and in distance) as spans to shade
/// on a time (`by_time`) or distance axis.
pub(super) fn fault_spans(faults: &[([f64; 2], [f64; 2])], by_time: bool) -> Vec<(f64, f64)> {
    faults
        .iter()
        .map(|(t, d)| if by_time { (t[0], t[1]) } else { (d[0], d[1]) })
        .collect()
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    s: &ErrorSeries,
    d: &PlotDecor,
    caption: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: &dyn std::fmt::Display| Error::InvalidParameter(format!("plot: {e}"));
    root.fill(&WHITE).map_err(|e| err(&e))?;
    // The legend in a column of its own right of the plot: it never hides data.
    let (w_px, _) = root.dim_in_pixel();
    let legend_w = (w_px / 4).clamp(200, 300);
    let (root, legend_area) = root.split_horizontally(w_px - legend_w);
    let mut legend: Vec<(String, RGBColor, LegendMark)> = Vec::new();
    let mut x_max = s.x.iter().copied().fold(0.0f64, f64::max).max(1e-9);
    if let Some((ex, _)) = &s.envelope {
        x_max = x_max.max(ex.iter().copied().fold(0.0, f64::max));
    }
    let mut y_max = s.error.iter().copied().fold(0.0f64, f64::max);
    for b in s.bound95.iter().flatten() {
        y_max = y_max.max(*b);
    }
    if let Some((_, env)) = &s.envelope {
        y_max = y_max.max(env[2].iter().copied().fold(0.0, f64::max));
    }
    if let Some(r) = d.requirement_m {
        y_max = y_max.max(r * 1.1);
    }
    let data_max = y_max;
    let y_max = match d.y_max {
        Some(m) if m > 0.0 => y_max.min(m),
        _ => y_max,
    };
    let y_max = if y_max > 0.0 { y_max * 1.05 } else { 1.0 };
    let clip = |v: f64| v.min(y_max);
    let mut builder = ChartBuilder::on(&root);
    if caption {
        builder.caption(&d.title, (FONT, 20));
    }
    let mut chart = builder
        .margin(12)
        .margin_top(20)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..x_max, 0.0..y_max)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc(&d.x_label)
        .y_desc(d.y_label.as_deref().unwrap_or("horizontal error (m)"))
        .label_style((FONT, 13))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|e| err(&e))?;
    if !d.shaded.is_empty() {
        chart
            .draw_series(d.shaded.iter().map(|&(a, b)| {
                Rectangle::new(
                    [(a.max(0.0), 0.0), (b.min(x_max), y_max)],
                    RGBAColor(255, 165, 0, 0.18).filled(),
                )
            }))
            .map_err(|e| err(&e))?;
        legend.push((
            "odometer fault".into(),
            RGBColor(255, 200, 120),
            LegendMark::Box,
        ));
    }
    if let Some((ex, env)) = &s.envelope {
        let names = [
            "median over runs",
            "95th percentile over runs",
            "max over runs",
        ];
        let colours = [
            RGBColor(23, 190, 207),
            RGBColor(255, 127, 14),
            RGBColor(140, 140, 140),
        ];
        for k in 0..3 {
            let c = colours[k];
            chart
                .draw_series(LineSeries::new(
                    ex.iter().copied().zip(env[k].iter().map(|&v| clip(v))),
                    c.stroke_width(1),
                ))
                .map_err(|e| err(&e))?;
            legend.push((names[k].into(), c, LegendMark::Line));
        }
    }
    let bound: Vec<(f64, f64)> =
        s.x.iter()
            .zip(&s.bound95)
            .filter_map(|(x, b)| b.map(|b| (*x, clip(b))))
            .collect();
    if !bound.is_empty() {
        let c = RGBColor(0, 140, 70);
        chart
            .draw_series(LineSeries::new(bound, c.stroke_width(2)))
            .map_err(|e| err(&e))?;
        legend.push((
            d.bound_label
                .as_deref()
                .unwrap_or("filter 95 % bound")
                .into(),
            c,
            LegendMark::Line,
        ));
    }
    let c = RGBColor(20, 70, 200);
    chart
        .draw_series(LineSeries::new(
            s.x.iter().copied().zip(s.error.iter().map(|&v| clip(v))),
            c.stroke_width(2),
        ))
        .map_err(|e| err(&e))?;
    legend.push((
        d.error_label
            .as_deref()
            .unwrap_or("horizontal error (run 0)")
            .into(),
        c,
        LegendMark::Line,
    ));
    if let Some(r) = d.requirement_m {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(0.0, r), (x_max, r)],
                8,
                5,
                RED.stroke_width(2),
            ))
            .map_err(|e| err(&e))?;
        legend.push((format!("requirement {r} m"), RED, LegendMark::Dashed));
    }
    for (kind, colour, height, label) in [
        (
            PassKind::Missed,
            RGBColor(150, 150, 150),
            0.04,
            "tag missed",
        ),
        (
            PassKind::Rejected,
            RGBColor(200, 30, 30),
            0.055,
            "tag read, rejected by the filter",
        ),
        (
            PassKind::Accepted,
            RGBColor(180, 0, 160),
            0.07,
            d.tag_label.as_deref().unwrap_or("tag read"),
        ),
    ] {
        let xs: Vec<f64> = d
            .tag_passes
            .iter()
            .filter(|m| m.kind == kind && m.x >= 0.0 && m.x <= x_max)
            .map(|m| m.x)
            .collect();
        if xs.is_empty() {
            continue;
        }
        chart
            .draw_series(xs.into_iter().map(move |x| {
                PathElement::new(vec![(x, 0.0), (x, y_max * height)], colour.stroke_width(2))
            }))
            .map_err(|e| err(&e))?;
        legend.push((label.into(), colour, LegendMark::Tick));
    }
    // Curves clipped at the top of the axis: a marker where each clipped
    // stretch starts, and the true maximum in the legend.
    if data_max > y_max {
        let mut starts = Vec::new();
        let mut check = |xs: &mut dyn Iterator<Item = (f64, f64)>| {
            let mut above = false;
            for (x, v) in xs {
                if v >= y_max && !above {
                    starts.push(x);
                }
                above = v >= y_max;
            }
        };
        check(&mut s.x.iter().copied().zip(s.error.iter().copied()));
        check(
            &mut s
                .x
                .iter()
                .zip(&s.bound95)
                .filter_map(|(x, b)| b.map(|b| (*x, b))),
        );
        if let Some((ex, env)) = &s.envelope {
            check(&mut ex.iter().copied().zip(env[2].iter().copied()));
        }
        let c = RGBColor(90, 0, 60);
        chart
            .draw_series(
                starts
                    .into_iter()
                    .map(|x| TriangleMarker::new((x, y_max * 0.985), 7, c.filled())),
            )
            .map_err(|e| err(&e))?;
        let up_to = match &d.y_unit {
            None => format!("{data_max:.0} m"),
            Some(unit) => {
                let digits = 2i64
                    .saturating_sub(data_max.abs().log10().floor() as i64)
                    .clamp(0, 12) as usize;
                format!("{data_max:.digits$} {unit}")
            }
        };
        legend.push((
            format!("clipped at the top: values up to {up_to}"),
            c,
            LegendMark::Triangle,
        ));
    }
    let title_style = TextStyle::from((FONT, 13).into_font()).color(&BLACK);
    let mut y = 30;
    for (label, colour, mark) in &legend {
        let colour = *colour;
        match mark {
            LegendMark::Line => legend_area.draw(&PathElement::new(
                vec![(8, y), (28, y)],
                colour.stroke_width(2),
            )),
            LegendMark::Dashed => legend_area
                .draw(&PathElement::new(
                    vec![(8, y), (14, y)],
                    colour.stroke_width(2),
                ))
                .and_then(|_| {
                    legend_area.draw(&PathElement::new(
                        vec![(20, y), (28, y)],
                        colour.stroke_width(2),
                    ))
                }),
            LegendMark::Tick => legend_area.draw(&PathElement::new(
                vec![(18, y - 6), (18, y + 6)],
                colour.stroke_width(2),
            )),
            LegendMark::Box => {
                legend_area.draw(&Rectangle::new([(8, y - 5), (28, y + 5)], colour.filled()))
            }
            LegendMark::Triangle => {
                legend_area.draw(&TriangleMarker::new((18, y), 6, colour.filled()))
            }
        }
        .map_err(|e| err(&e))?;
        // Long labels wrap onto further lines.
        let lines = wrap(label, (legend_w as usize - 40) / 6);
        for (k, line) in lines.iter().enumerate() {
            legend_area
                .draw(&Text::new(
                    line.clone(),
                    (34, y - 7 + 15 * k as i32),
                    title_style.clone(),
                ))
                .map_err(|e| err(&e))?;
        }
        y += 8 + 15 * lines.len() as i32;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// How a legend entry is drawn.
#[derive(Debug, Clone, Copy)]
enum LegendMark {
    Line,
    Dashed,
    Tick,
    Box,
    Triangle,
}

/// Splits a label into lines of at most about `width` characters, at spaces.
fn wrap(label: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for word in label.split(' ') {
        if !cur.is_empty() && cur.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// The plot as an SVG document.
pub fn error_plot_svg(s: &ErrorSeries, d: &PlotDecor, size: (u32, u32)) -> Result<String> {
    register_font();
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        draw(root, s, d, false)?;
    }
    Ok(out)
}

/// The plot as a PNG file's bytes.
pub fn error_plot_png(s: &ErrorSeries, d: &PlotDecor, size: (u32, u32)) -> Result<Vec<u8>> {
    register_font();
    let (w, h) = size;
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw(root, s, d, true)?;
    }
    encode_png(&rgb, w, h)
}

/// Encodes an RGB buffer as PNG (crate `png`).
fn encode_png(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let err = |e: png::EncodingError| Error::InvalidParameter(format!("PNG encoding: {e}"));
        let mut writer = enc.write_header().map_err(err)?;
        writer.write_image_data(rgb).map_err(err)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(top: f64) -> ErrorSeries {
        ErrorSeries {
            x: (0..100).map(f64::from).collect(),
            error: (0..100).map(|i| top * f64::from(i) / 99.0).collect(),
            bound95: vec![None; 100],
            envelope: None,
        }
    }

    #[test]
    fn a_curve_clipped_at_the_axis_is_marked_with_its_true_maximum() {
        let decor = PlotDecor {
            title: "t".into(),
            x_label: "x".into(),
            requirement_m: Some(20.0),
            y_max: Some(50.0),
            ..Default::default()
        };
        // 286 m shown on a 50 m axis (issue 16's "26 m shown for 286 m").
        let svg = error_plot_svg(&series(286.0), &decor, (900, 400)).unwrap();
        // The legend (wrapped over lines) names the true maximum.
        assert!(svg.contains("clipped at the top"), "{svg}");
        assert!(svg.contains("286 m\n</text>"), "{svg}");
        // One marker where the curve leaves the axis.
        assert_eq!(svg.matches("<polygon").count(), 2, "marker and its legend");
        // Not clipped: no mark.
        let svg = error_plot_svg(&series(30.0), &decor, (900, 400)).unwrap();
        assert!(!svg.contains("clipped"));
    }

    #[test]
    fn the_legend_is_drawn_right_of_the_plot_area() {
        let decor = PlotDecor {
            title: "t".into(),
            x_label: "x".into(),
            requirement_m: Some(20.0),
            ..Default::default()
        };
        let svg = error_plot_svg(&series(30.0), &decor, (900, 400)).unwrap();
        // The legend's text starts right of the plotting area's right edge
        // (the chart takes the width less the legend column).
        let legend_w = (900 / 4).clamp(200, 300);
        let i = svg.find("requirement 20 m").unwrap();
        let tag = &svg[svg[..i].rfind("<text").unwrap()..i];
        let x: f64 = tag
            .split("x=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(x >= f64::from(900 - legend_w), "{x}");
    }
}
