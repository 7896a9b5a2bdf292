//! Charts of sampled values as SVG text or PNG bytes: the recordings of
//! `axisctl record` (drawn by `axisctl plot`) and the dashboard's chart
//! snapshots share it.
//!
//! Values of different units never share a y axis: the chart is split into
//! stacked panels, one per unit, over one time axis. Every series is one line
//! of its own colour with a legend entry naming it.
//!
//! Pure: data in, text or bytes out, no I/O and nothing else of the crate.
//! plotters' SVG backend writes `<text>` elements; the PNG is drawn by its
//! bitmap backend with Noto Sans compiled into the binary (the
//! `ttf-noto-sans` crate, Apache-2.0) and encoded by the pure-Rust `png`
//! crate, so neither needs a system font or library. The same font measures
//! the SVG's labels, so both place them alike.

use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

/// One sampled value over time.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry, e.g. "17 ActPos".
    pub name: String,
    /// Unit of the values, e.g. "m/s"; series of one unit share a panel.
    pub unit: Option<String>,
    /// (t in seconds, value). Non-finite points are left out of the drawing.
    pub points: Vec<(f64, f64)>,
}

/// What to draw: the series and the labels around them.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    pub title: String,
    /// Label of the shared time axis, e.g. "t (s)".
    pub x_label: String,
    pub series: Vec<Series>,
}

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("a chart of {width}x{height} pixels is too small to draw (at least {MIN_WIDTH}x{MIN_HEIGHT} per panel)")]
    TooSmall { width: u32, height: u32 },
    #[error("a PNG of {width}x{height} pixels is too large (at most {MAX_PNG_PIXELS} pixels)")]
    TooLarge { width: u32, height: u32 },
    #[error("drawing the chart failed: {0}")]
    Draw(String),
}

/// The largest PNG drawn, in pixels: its RGB buffer is held in memory
/// (3 bytes a pixel), so 8000x4000 and the like but not 20000x20000.
pub const MAX_PNG_PIXELS: u64 = 32_000_000;

/// Below this a panel has no room for its axes and labels.
pub const MIN_WIDTH: u32 = 120;
pub const MIN_HEIGHT: u32 = 80;

/// Stroke width of the data lines: every `<polyline>` of this width in the
/// document is one series (axes and ticks are drawn at width 1).
pub const LINE_WIDTH: u32 = 2;

/// Distinct colours in order; a chart with more series cycles through them.
const COLOURS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// The colour of the `index`-th series of a chart (the dashboard matches it).
pub fn colour(index: usize) -> (u8, u8, u8) {
    let RGBColor(r, g, b) = COLOURS[index % COLOURS.len()];
    (r, g, b)
}

/// The units of the chart's panels, in order of first appearance; `None` is
/// the panel of series without a unit.
pub fn panels(chart: &Chart) -> Vec<Option<String>> {
    let mut units: Vec<Option<String>> = Vec::new();
    for s in &chart.series {
        if !units.contains(&s.unit) {
            units.push(s.unit.clone());
        }
    }
    units
}

/// The y-axis label of a panel: the names of its series (when they fit) and
/// the unit in brackets, e.g. "ActVel [m/s]".
fn y_label(chart: &Chart, unit: &Option<String>) -> String {
    let names: Vec<&str> = chart.series.iter().filter(|s| &s.unit == unit).map(|s| s.name.as_str()).collect();
    let names = if names.len() == 1 { names[0].to_string() } else { "value".to_string() };
    match unit {
        Some(u) => format!("{names} [{u}]"),
        None => names,
    }
}

fn finite(points: &[(f64, f64)]) -> impl Iterator<Item = (f64, f64)> + '_ {
    points.iter().copied().filter(|(t, v)| t.is_finite() && v.is_finite())
}

/// A range that contains every value and is never empty: a single value or
/// none at all still gives an axis to draw.
fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
        let pad = if lo.abs() > 0.0 { lo.abs() * 0.1 } else { 1.0 };
        return (lo - pad, hi + pad);
    }
    let pad = (hi - lo) * 0.05;
    (lo - pad, hi + pad)
}

fn draw_err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// The font plotters lays out (SVG) and draws (PNG) every label with,
/// registered once per process under the family name the chart asks for.
fn font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, ttf_noto_sans::REGULAR).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Draw("the embedded font does not load".into()))
    }
}

fn check_size(chart: &Chart, width: u32, height: u32) -> Result<(), PlotError> {
    let rows = panels(chart).len().max(1) as u32;
    if width < MIN_WIDTH || height < MIN_HEIGHT * rows + 30 {
        return Err(PlotError::TooSmall { width, height });
    }
    font()
}

/// The chart as an SVG document of `width` x `height` pixels.
pub fn svg(chart: &Chart, width: u32, height: u32) -> Result<String, PlotError> {
    check_size(chart, width, height)?;
    let mut out = String::new();
    draw(SVGBackend::with_string(&mut out, (width, height)).into_drawing_area(), chart)?;
    Ok(out)
}

/// The chart as a PNG image (8-bit RGB) of `width` x `height` pixels.
pub fn png(chart: &Chart, width: u32, height: u32) -> Result<Vec<u8>, PlotError> {
    check_size(chart, width, height)?;
    if u64::from(width) * u64::from(height) > MAX_PNG_PIXELS {
        return Err(PlotError::TooLarge { width, height });
    }
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    draw(BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area(), chart)?;
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header().and_then(|mut w| w.write_image_data(&rgb)).map_err(draw_err)?;
    Ok(out)
}

/// Draws the chart on any plotters backend: the title, then one panel per
/// unit stacked over the shared time axis.
fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, chart: &Chart) -> Result<(), PlotError> {
    let units = panels(chart);
    let rows = units.len().max(1) as u32;
    let x = range(chart.series.iter().flat_map(|s| finite(&s.points).map(|(t, _)| t)));
    root.fill(&WHITE).map_err(draw_err)?;
    let root = root.titled(&chart.title, ("sans-serif", 18)).map_err(draw_err)?;
    let areas = root.split_evenly((rows as usize, 1));
    if units.is_empty() {
        // Nothing to draw: still an empty panel with its axes, so a
        // recording without samples gives a readable picture.
        let mut c = ChartBuilder::on(&areas[0])
            .margin(8)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d(x.0..x.1, 0.0..1.0)
            .map_err(draw_err)?;
        c.configure_mesh().x_desc(chart.x_label.as_str()).draw().map_err(draw_err)?;
    }
    for (row, (unit, area)) in units.iter().zip(areas.iter()).enumerate() {
        let members: Vec<(usize, &Series)> = chart.series.iter().enumerate().filter(|(_, s)| &s.unit == unit).collect();
        let y = range(members.iter().flat_map(|(_, s)| finite(&s.points).map(|(_, v)| v)));
        let mut c = ChartBuilder::on(area)
            .margin(8)
            .x_label_area_size(35)
            .y_label_area_size(70)
            .build_cartesian_2d(x.0..x.1, y.0..y.1)
            .map_err(draw_err)?;
        let mut mesh = c.configure_mesh();
        mesh.y_desc(y_label(chart, unit)).light_line_style(RGBColor(235, 235, 235));
        // The panels share the time axis: its name once, under the last.
        if row + 1 == units.len() {
            mesh.x_desc(chart.x_label.as_str());
        }
        mesh.draw().map_err(draw_err)?;
        for (index, s) in members {
            let colour = COLOURS[index % COLOURS.len()];
            let points: Vec<(f64, f64)> = finite(&s.points).collect();
            if points.len() == 1 {
                // A single sample is no line: a dot shows it.
                c.draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled()))).map_err(draw_err)?;
            }
            let label = match &s.unit {
                Some(u) => format!("{} [{u}]", s.name),
                None => s.name.clone(),
            };
            // The legend's mark is a rectangle, so every polyline of
            // the document is a data line.
            c.draw_series(LineSeries::new(points, colour.stroke_width(LINE_WIDTH)))
                .map_err(draw_err)?
                .label(label)
                .legend(move |(x, y)| Rectangle::new([(x, y - 4), (x + 14, y + 4)], colour.filled()));
        }
        c.configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(draw_err)?;
    }
    root.present().map_err(draw_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(name: &str, unit: Option<&str>, points: &[(f64, f64)]) -> Series {
        Series { name: name.into(), unit: unit.map(Into::into), points: points.to_vec() }
    }

    fn chart(series: Vec<Series>) -> Chart {
        Chart { title: "step response".into(), x_label: "t (s)".into(), series }
    }

    /// Data lines: the polylines of width [`LINE_WIDTH`] (axes and ticks are 1).
    fn lines(svg: &str) -> Vec<&str> {
        svg.split("<polyline").skip(1).filter(|p| p.contains(&format!("stroke-width=\"{LINE_WIDTH}\""))).collect()
    }

    /// The text of every `<text>` element.
    fn texts(svg: &str) -> Vec<String> {
        svg.split("<text")
            .skip(1)
            .filter_map(|t| Some(t[t.find('>')? + 1..t.find("</text>")?].trim().to_string()))
            .collect()
    }

    #[test]
    fn one_line_per_series_and_units_on_the_axes() {
        let c = chart(vec![
            series("ActPos", Some("m"), &[(0.0, 0.0), (0.5, 0.05), (1.0, 0.1)]),
            series("ActVel", Some("m/s"), &[(0.0, 0.0), (0.5, 0.2), (1.0, 0.0)]),
            series("ActCur", Some("A"), &[(0.0, 0.1), (0.5, 1.5), (1.0, 0.2)]),
        ]);
        let svg = svg(&c, 800, 600).unwrap();
        assert!(svg.starts_with("<svg"), "{svg}");
        assert_eq!(lines(&svg).len(), 3, "{svg}");
        let texts = texts(&svg);
        for label in ["ActPos [m]", "ActVel [m/s]", "ActCur [A]", "t (s)", "step response"] {
            assert!(texts.iter().any(|t| t == label), "no {label:?} in {texts:?}");
        }
        // Three distinct colours, one per line.
        let strokes: std::collections::BTreeSet<&str> =
            lines(&svg).into_iter().filter_map(|p| p.split("stroke=\"").nth(1)?.split('"').next()).collect();
        assert_eq!(strokes.len(), 3, "{strokes:?}");
    }

    #[test]
    fn series_of_one_unit_share_a_panel() {
        let c = chart(vec![
            series("17 ActPos", Some("m"), &[(0.0, 0.0), (1.0, 0.1)]),
            series("18 ActPos", Some("m"), &[(0.0, 0.2), (1.0, 0.3)]),
        ]);
        assert_eq!(panels(&c), vec![Some("m".to_string())]);
        let svg = svg(&c, 640, 400).unwrap();
        assert_eq!(lines(&svg).len(), 2);
        let texts = texts(&svg);
        assert!(texts.iter().any(|t| t == "value [m]"), "{texts:?}");
        assert!(texts.iter().any(|t| t == "17 ActPos [m]") && texts.iter().any(|t| t == "18 ActPos [m]"), "{texts:?}");
    }

    #[test]
    fn empty_single_point_and_non_finite_series_draw_without_panicking() {
        let c = chart(vec![
            series("empty", Some("m"), &[]),
            series("one", Some("A"), &[(0.3, 2.0)]),
            series("nan", None, &[(f64::NAN, 1.0), (0.0, f64::INFINITY)]),
        ]);
        let drawn = svg(&c, 640, 600).unwrap();
        assert!(drawn.contains("<circle"), "the single sample is drawn as a dot");
        assert!(drawn.trim_end().ends_with("</svg>"));
        assert!(svg(&chart(vec![]), 640, 400).unwrap().contains("t (s)"));
        let flat = chart(vec![series("flat", Some("m"), &[(0.0, 0.0), (1.0, 0.0)])]);
        assert_eq!(lines(&svg(&flat, 640, 400).unwrap()).len(), 1);
    }

    #[test]
    fn a_png_is_an_rgb_image_of_the_size_asked() {
        let c = chart(vec![series("ActPos", Some("m"), &[(0.0, 0.0), (1.0, 0.1)])]);
        let bytes = png(&c, 320, 200).unwrap();
        let mut reader = ::png::Decoder::new(std::io::Cursor::new(bytes)).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height, info.color_type), (320, 200, ::png::ColorType::Rgb));
        let (r, g, b) = colour(0);
        assert!(buf.chunks_exact(3).any(|p| p == [r, g, b]), "the line is drawn in its colour");
        assert!(matches!(png(&c, 20000, 20000), Err(PlotError::TooLarge { .. })));
    }

    #[test]
    fn too_small_is_an_error_not_a_panic() {
        let c = chart(vec![series("a", Some("m"), &[(0.0, 1.0)]), series("b", Some("A"), &[(0.0, 1.0)])]);
        assert!(matches!(svg(&c, 10, 10), Err(PlotError::TooSmall { .. })));
        assert!(matches!(svg(&c, 640, 150), Err(PlotError::TooSmall { .. })));
        assert!(matches!(png(&c, 10, 10), Err(PlotError::TooSmall { .. })));
    }
}
