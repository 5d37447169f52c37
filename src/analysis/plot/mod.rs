//! Log-log convergence plots: error against run time, one line per sampler.
//!
//! [`write_plot`] draws the plot as PNG or SVG with the `plotters` crate; the slope shown in
//! the legend comes from [`super::fit::log_log_slope`].
//!
//! Text in PNG output is rasterised with a font compiled into the binary (a
//! subset of DejaVu Sans, see `assets/fonts/`), so plotting needs no system
//! fonts or font libraries. SVG output leaves text to the viewer and refers to
//! no other file.

use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::combinators::{LogCoord, WithKeyPoints};
use plotters::coord::{CoordTranslate, Shift};
use plotters::element::ComposedElement;
use plotters::prelude::*;
use plotters::style::{FontStyle, TextStyle, register_font};

mod ticks;

use super::fit::usable;
use raytrace_core::format::Format;
use raytrace_io as io;
use ticks::{TickFormat, axis_range, log_ticks, tick_format, tick_label};

/// The formats a plot can be written in.
const PLOT_FORMATS: &[Format] = &[Format::Png, Format::Svg];

/// One line of the plot.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Series {
    /// Legend name of the line, such as the sampler's name.
    pub(crate) name: String,
    /// The measurements, as `(seconds, error)` pairs, joined in this order.
    /// Points that cannot be shown on log axes (non-positive or non-finite)
    /// are skipped.
    pub(crate) points: Vec<(f64, f64)>,
    /// Fitted log-log slope shown in the legend, as from [`super::fit::log_log_slope`];
    /// a non-finite slope is not shown.
    pub(crate) slope: Option<f64>,
    /// Each point's spread, drawn as bars through it (none when empty): its `x` and `y`
    /// ranges. A bar's end that log axes cannot show is drawn to the axis' end.
    pub(crate) bars: Vec<Bar>,
}

/// A point's spread: the ranges of its `x` and of its `y`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bar {
    pub(crate) x: (f64, f64),
    pub(crate) y: (f64, f64),
}

/// What is drawn behind the series to read them by: horizontal levels, and a line of a
/// given slope.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Guides {
    /// Horizontal lines at these `y`, each labelled at its right end.
    pub(crate) levels: Vec<(f64, String)>,
    /// A straight line on the log-log axes through a point with a slope, named in the legend.
    pub(crate) slope: Option<SlopeGuide>,
}

/// A dashed line of slope `slope` through `through`, named `name` in the legend.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SlopeGuide {
    pub(crate) through: (f64, f64),
    pub(crate) slope: f64,
    pub(crate) name: String,
}

/// Width and height in pixels of every plot (PNG pixels, SVG user units).
const PLOT_SIZE: (u32, u32) = (1000, 700);

/// Writes a log-log plot of error against seconds to `path`; the format follows the extension
/// (`.png` or `.svg`, case-insensitive); any other extension is an `Err(String)` naming the path.
///
/// The legend shows each series' name and, when present, its fitted slope
/// (`"independent (slope -0.98)"`), in the corner of the plot that covers the least data. Axes
/// are labelled with `x_label`/`y_label`, and the plot has the title `title`. Points are drawn
/// as markers (a distinct colour and shape per series) joined by lines.
///
/// Both axes are logarithmic, with ranges covering all finite positive points with a margin
/// and spanning at least one decade; non-positive or non-finite points are skipped (never
/// panics), and an empty plot (no usable points) still writes a valid file. The image is
/// 1000 × 700 pixels. Errors (I/O, drawing) become `Err(String)` naming the path.
pub(crate) fn write_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    guides: &Guides,
) -> Result<(), String> {
    let format = Format::of(path, PLOT_FORMATS, "plot")?;
    register_embedded_font().map_err(|e| {
        format!(
            "cannot write plot {}: {e}",
            raytrace_core::error::elide_path(path)
        )
    })?;
    let labels = Labels {
        title,
        x: x_label,
        y: y_label,
    };
    let drawing_error = |e: String| {
        format!(
            "cannot draw plot {}: {e}",
            raytrace_core::error::elide_path(path)
        )
    };
    let (width, height) = PLOT_SIZE;
    match format {
        Format::Png => {
            let mut pixels = vec![255u8; width as usize * height as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut pixels, PLOT_SIZE).into_drawing_area();
                draw(&root, &labels, series, guides).map_err(drawing_error)?;
                root.present().map_err(|e| drawing_error(e.to_string()))?;
            }
            let image = image::RgbImage::from_raw(width, height, pixels)
                .ok_or_else(|| drawing_error("pixel buffer has the wrong size".to_string()))?;
            let mut png = std::io::Cursor::new(Vec::new());
            image
                .write_to(&mut png, image::ImageFormat::Png)
                .map_err(|e| drawing_error(e.to_string()))?;
            write(path, &png.into_inner())
        }
        _ => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, PLOT_SIZE).into_drawing_area();
                draw(&root, &labels, series, guides).map_err(drawing_error)?;
                root.present().map_err(|e| drawing_error(e.to_string()))?;
            }
            write(path, svg.as_bytes())
        }
    }
}

/// Checks that a plot can be written to `path` in a format its extension names, before
/// anything is measured or drawn.
pub(crate) fn check_path(path: &Path) -> Result<(), String> {
    Format::of(path, PLOT_FORMATS, "plot").map(|_| ())
}

/// Writes the plot's bytes atomically.
fn write(path: &Path, bytes: &[u8]) -> Result<(), String> {
    io::write_file(path, bytes).map_err(|e| format!("cannot write plot {e}"))
}

/// The texts around the plot.
struct Labels<'a> {
    title: &'a str,
    x: &'a str,
    y: &'a str,
}

/// The embedded font: DejaVu Sans, subset (see `assets/fonts/README.md`).
static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans-subset.ttf");

/// Font family name used for all text; the embedded font is registered under it.
const FAMILY: &str = "sans-serif";

/// Registers the embedded font with plotters once per process.
fn register_embedded_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            register_font(FAMILY, FontStyle::Normal, FONT)
                .map_err(|_| "the embedded font cannot be read".to_string())
        })
        .clone()
}

/// Line colours (the Tableau 10 palette): distinct, and readable on white.
const PALETTE: [RGBColor; 10] = [
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

/// Marker shapes, cycled through with the colours so that lines stay apart in grey print.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
}

const SHAPES: [Shape; 5] = [
    Shape::Circle,
    Shape::Square,
    Shape::TriangleUp,
    Shape::Diamond,
    Shape::TriangleDown,
];

/// Marker radius in pixels.
const MARKER_RADIUS: f64 = 5.0;

/// Outline of a marker around (0, 0), in pixel offsets (y down).
fn marker_outline(shape: Shape, centre: (i32, i32)) -> Vec<(i32, i32)> {
    let r = MARKER_RADIUS;
    let corners: Vec<(f64, f64)> = match shape {
        Shape::Circle => (0..16)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 16.0;
                (r * a.cos(), r * a.sin())
            })
            .collect(),
        Shape::Square => {
            let h = r * 0.85;
            vec![(-h, -h), (h, -h), (h, h), (-h, h)]
        }
        Shape::TriangleUp => vec![(0.0, -r * 1.2), (r * 1.1, r * 0.8), (-r * 1.1, r * 0.8)],
        Shape::TriangleDown => vec![(0.0, r * 1.2), (r * 1.1, -r * 0.8), (-r * 1.1, -r * 0.8)],
        Shape::Diamond => vec![(0.0, -r * 1.25), (r, 0.0), (0.0, r * 1.25), (-r, 0.0)],
    };
    corners
        .into_iter()
        .map(|(x, y)| (centre.0 + x.round() as i32, centre.1 + y.round() as i32))
        .collect()
}

/// A marker element: an anchor with a filled outline and a rim drawn relative to it.
type Marker<C, DB> = ComposedElement<C, DB, Polygon<(i32, i32)>, PathElement<(i32, i32)>>;

/// A filled marker with a thin white rim, centred `centre` pixels from `at`
/// (data or backend coordinates).
fn marker<C, DB: DrawingBackend>(
    at: C,
    shape: Shape,
    colour: RGBColor,
    centre: (i32, i32),
) -> Marker<C, DB> {
    let outline = marker_outline(shape, centre);
    let mut rim = outline.clone();
    rim.push(outline[0]);
    EmptyElement::at(at)
        + Polygon::new(outline, colour.filled())
        + PathElement::new(rim, WHITE.stroke_width(1))
}

/// The legend text of a series.
fn legend_label(series: &Series) -> String {
    match series.slope {
        Some(slope) if slope.is_finite() => {
            let slope = format!("{slope:.2}");
            // A slope that rounds to zero reads better without a sign.
            let slope = if slope == "-0.00" { "0.00" } else { &slope };
            format!("{} (slope {slope})", series.name)
        }
        _ => series.name.clone(),
    }
}

/// Corners the legend can go in, in order of preference: a convergence plot's lines fall
/// from upper left to lower right, leaving the upper right and lower left free.
const LEGEND_CORNERS: [SeriesLabelPosition; 4] = [
    SeriesLabelPosition::UpperRight,
    SeriesLabelPosition::LowerLeft,
    SeriesLabelPosition::UpperLeft,
    SeriesLabelPosition::LowerRight,
];

/// Index into [`LEGEND_CORNERS`] of the corner where a legend of `legend` pixels covers
/// the fewest of the `lines` (pixel coordinates relative to the plotting area of size
/// `area`), sampled along their segments; the earliest such corner on a tie.
fn legend_corner(lines: &[Vec<(i32, i32)>], area: (u32, u32), legend: (u32, u32)) -> usize {
    // Mirrors the 5-pixel inset of plotters' named legend positions, plus room for markers.
    let inset = 5.0;
    let pad = MARKER_RADIUS + 2.0;
    let (aw, ah) = (f64::from(area.0), f64::from(area.1));
    let (lw, lh) = (f64::from(legend.0), f64::from(legend.1));
    let boxes: Vec<(Range<f64>, Range<f64>)> =
        [(false, true), (true, false), (true, true), (false, false)]
            .iter()
            .map(|&(left, top)| {
                let x = if left { inset } else { aw - lw - inset };
                let y = if top { inset } else { ah - lh - inset };
                (x - pad..x + lw + pad, y - pad..y + lh + pad)
            })
            .collect();
    let mut covered = [0usize; 4];
    let mut count = |x: f64, y: f64| {
        for (c, (bx, by)) in covered.iter_mut().zip(&boxes) {
            if bx.contains(&x) && by.contains(&y) {
                *c += 1;
            }
        }
    };
    for line in lines {
        for (i, &(x, y)) in line.iter().enumerate() {
            // Markers weigh more than line samples: hiding a measurement is worse.
            for _ in 0..8 {
                count(f64::from(x), f64::from(y));
            }
            if let Some(&(nx, ny)) = line.get(i + 1) {
                const SAMPLES: i32 = 16;
                for s in 1..SAMPLES {
                    let t = f64::from(s) / f64::from(SAMPLES);
                    count(
                        f64::from(x) + t * f64::from(nx - x),
                        f64::from(y) + t * f64::from(ny - y),
                    );
                }
            }
        }
    }
    (0..covered.len())
        .min_by_key(|&i| (covered[i], i))
        .unwrap_or(0)
}

/// A series as drawn: its style and its usable points.
struct Line {
    colour: RGBColor,
    shape: Shape,
    points: Vec<(f64, f64)>,
}

/// Text sizes in pixels.
const TITLE_SIZE: f64 = 28.0;
const AXIS_LABEL_SIZE: f64 = 21.0;
const TICK_LABEL_SIZE: f64 = 17.0;
const LEGEND_SIZE: f64 = 18.0;

/// The plot's coordinates: log axes, each with its major and minor ticks.
type LogLog = Cartesian2d<WithKeyPoints<LogCoord<f64>>, WithKeyPoints<LogCoord<f64>>>;

/// Draws the whole plot on `root`.
fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    labels: &Labels,
    series: &[Series],
    guides: &Guides,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let (x_range, y_range) = axis_ranges(series, guides);
    let ranges = (&x_range, &y_range);
    let mut chart = chart(root, labels, ranges).map_err(err)?;
    draw_guides(&mut chart, guides, ranges).map_err(err)?;
    let lines: Vec<Line> = series
        .iter()
        .enumerate()
        .map(|(i, s)| Line {
            colour: PALETTE[i % PALETTE.len()],
            shape: SHAPES[i % SHAPES.len()],
            points: s.points.iter().copied().filter(|&p| usable(p)).collect(),
        })
        .collect();
    // All lines first, then all markers, so that no line hides a measurement.
    draw_lines(&mut chart, series, &lines).map_err(err)?;
    for (s, line) in series.iter().zip(&lines) {
        draw_bars(&mut chart, s, line.colour, ranges).map_err(err)?;
    }
    for line in &lines {
        chart
            .draw_series(
                line.points
                    .iter()
                    .map(|&p| marker::<_, DB>(p, line.shape, line.colour, (0, 0))),
            )
            .map_err(err)?;
    }
    if !series.is_empty() {
        draw_legend(root, &mut chart, (series, guides), &lines).map_err(err)?;
    }
    Ok(())
}

/// The axes' ranges: of the usable points' `x`, and of their `y` with the levels'.
fn axis_ranges(series: &[Series], guides: &Guides) -> (Range<f64>, Range<f64>) {
    let usable_points = || {
        series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&p| usable(p))
    };
    let x_range = axis_range(usable_points().map(|p| p.0));
    let levels = guides
        .levels
        .iter()
        .map(|l| l.0)
        .filter(|&y| usable((1.0, y)));
    let y_range = axis_range(usable_points().map(|p| p.1).chain(levels));
    (x_range, y_range)
}

/// The chart on `root`: its title, and log axes over `ranges` with their ticks labelled,
/// their descriptions and their mesh drawn.
fn chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    labels: &Labels,
    (x_range, y_range): (&Range<f64>, &Range<f64>),
) -> Result<ChartContext<'a, DB, LogLog>, DrawingAreaErrorKind<DB::ErrorType>>
where
    DB::ErrorType: 'static,
{
    let (x_major, x_minor) = log_ticks(x_range);
    let (y_major, y_minor) = log_ticks(y_range);
    let (x_format, y_format) = (tick_format(&x_major), tick_format(&y_major));
    let widest_y_tick = widest_label(root, &y_major, y_format)?;
    let mut builder = ChartBuilder::on(root);
    builder
        .margin_top(16)
        .margin_right(36)
        .margin_left(16)
        .margin_bottom(12)
        .x_label_area_size(64)
        .y_label_area_size(widest_y_tick + 52);
    if !labels.title.is_empty() {
        builder.caption(labels.title, (FAMILY, TITLE_SIZE));
    }
    let mut chart = builder.build_cartesian_2d(
        x_range
            .clone()
            .log_scale()
            .with_key_points(x_major)
            .with_light_points(x_minor),
        y_range
            .clone()
            .log_scale()
            .with_key_points(y_major)
            .with_light_points(y_minor),
    )?;
    let x_formatter = |v: &f64| tick_label(*v, x_format);
    let y_formatter = |v: &f64| tick_label(*v, y_format);
    chart
        .configure_mesh()
        .x_desc(labels.x)
        .y_desc(labels.y)
        .axis_desc_style((FAMILY, AXIS_LABEL_SIZE))
        .label_style((FAMILY, TICK_LABEL_SIZE))
        .x_label_formatter(&x_formatter)
        .y_label_formatter(&y_formatter)
        .bold_line_style(BLACK.mix(0.16))
        .light_line_style(BLACK.mix(0.06))
        .axis_style(BLACK.mix(0.75))
        .draw()?;
    Ok(chart)
}

/// The width in pixels, on `root`, of the widest label of the `ticks` written in `format`.
fn widest_label<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    ticks: &[f64],
    format: TickFormat,
) -> Result<u32, DrawingAreaErrorKind<DB::ErrorType>> {
    let tick_style = TextStyle::from((FAMILY, TICK_LABEL_SIZE).into_font());
    ticks
        .iter()
        .map(|&v| root.estimate_text_size(&tick_label(v, format), &tick_style))
        .try_fold(0, |w, size| size.map(|(tw, _)| w.max(tw)))
}

/// Draws each series' line on `chart`, with its legend entry: its label, and its line and
/// marker.
fn draw_lines<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, LogLog>,
    series: &[Series],
    lines: &[Line],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB::ErrorType: 'static,
{
    for (s, line) in series.iter().zip(lines) {
        let (colour, shape) = (line.colour, line.shape);
        chart
            .draw_series(LineSeries::new(line.points.clone(), colour.stroke_width(2)))?
            .label(legend_label(s))
            .legend(move |(x, y)| {
                let outline = marker_outline(shape, (14, 0));
                let mut rim = outline.clone();
                rim.push(outline[0]);
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (28, 0)], colour.stroke_width(2))
                    + Polygon::new(outline, colour.filled())
                    + PathElement::new(rim, WHITE.stroke_width(1))
            });
    }
    Ok(())
}

/// Draws the bars of `series`' usable points on `chart` in `colour`, each end within `ranges`
/// (an end that log axes cannot show at the axis' end).
fn draw_bars<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, LogLog>,
    series: &Series,
    colour: RGBColor,
    (x_range, y_range): (&Range<f64>, &Range<f64>),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB::ErrorType: 'static,
{
    let clamp = |v: f64, r: &Range<f64>| {
        if v.is_nan() {
            r.start
        } else {
            v.clamp(r.start, r.end)
        }
    };
    let bars = series
        .points
        .iter()
        .zip(&series.bars)
        .filter(|(p, _)| usable(**p));
    for (&(x, y), bar) in bars {
        let (x0, x1) = (clamp(bar.x.0, x_range), clamp(bar.x.1, x_range));
        let (y0, y1) = (clamp(bar.y.0, y_range), clamp(bar.y.1, y_range));
        let (x, y) = (clamp(x, x_range), clamp(y, y_range));
        for segment in [[(x0, y), (x1, y)], [(x, y0), (x, y1)]] {
            chart.draw_series(std::iter::once(PathElement::new(
                segment.to_vec(),
                colour.stroke_width(2),
            )))?;
        }
    }
    Ok(())
}

/// Draws the legend of the `series` and the slope guide of `guides` on `chart`, in the corner
/// of the plotting area where it hides the least of the `lines`.
fn draw_legend<'a, DB: DrawingBackend + 'a>(
    root: &DrawingArea<DB, Shift>,
    chart: &mut ChartContext<'a, DB, LogLog>,
    (series, guides): (&[Series], &Guides),
    lines: &[Line],
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB::ErrorType: 'static,
{
    let (margin, key_width) = (10u32, 40u32);
    let names: Vec<String> = series
        .iter()
        .map(legend_label)
        .chain(guides.slope.iter().map(|g| g.name.clone()))
        .collect();
    let (text_width, text_height) = legend_text_size(root, &names)?;
    let legend_size = (
        text_width + key_width + 2 * margin,
        text_height + 2 * margin,
    );
    let base = chart.plotting_area().get_base_pixel();
    let pixel_lines: Vec<Vec<(i32, i32)>> = lines
        .iter()
        .map(|line| {
            line.points
                .iter()
                .map(|p| {
                    let (x, y) = chart.backend_coord(p);
                    (x - base.0, y - base.1)
                })
                .collect()
        })
        .collect();
    let area = chart.plotting_area().dim_in_pixel();
    let corner = legend_corner(&pixel_lines, area, legend_size);
    chart
        .configure_series_labels()
        .position(LEGEND_CORNERS[corner].clone())
        .margin(margin)
        .legend_area_size(key_width)
        .label_font((FAMILY, LEGEND_SIZE))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.4))
        .draw()
}

/// The width and height in pixels, on `root`, of the legend's entries `names`, one a line.
fn legend_text_size<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    names: &[String],
) -> Result<(u32, u32), DrawingAreaErrorKind<DB::ErrorType>> {
    let legend_style = TextStyle::from((FAMILY, LEGEND_SIZE).into_font());
    let mut width = 0;
    for name in names {
        let (w, _) = root.estimate_text_size(name, &legend_style)?;
        width = width.max(w);
    }
    // Lines are spaced at 1.25 times the font size, as plotters lays them out.
    let height = (names.len() as f64 * LEGEND_SIZE * 1.25).ceil() as u32;
    Ok((width, height))
}

/// The colour of the guides: a bluish grey that stays behind the series (and that no text's
/// antialiasing, grey on white, makes).
const GUIDE: RGBColor = RGBColor(100, 112, 128);

/// Draws the guides on `chart`, within its `ranges`: each level as a dotted line labelled at
/// its right end, the slope guide as a dashed line (clipped to the ranges) in the legend.
fn draw_guides<'a, DB: DrawingBackend + 'a, CT: CoordTranslate<From = (f64, f64)>>(
    chart: &mut ChartContext<'a, DB, CT>,
    guides: &Guides,
    (x_range, y_range): (&Range<f64>, &Range<f64>),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB::ErrorType: 'static,
{
    for (y, label) in &guides.levels {
        if !usable((1.0, *y)) || !y_range.contains(y) {
            continue;
        }
        let ends = [(x_range.start, *y), (x_range.end, *y)];
        chart.draw_series(DashedLineSeries::new(ends, 3, 5, GUIDE.stroke_width(1)))?;
        let style = TextStyle::from((FAMILY, TICK_LABEL_SIZE).into_font()).color(&GUIDE);
        let text = EmptyElement::at((x_range.end, *y))
            + Text::new(label.clone(), (-8 - 9 * label.len() as i32, -20), style);
        chart.draw_series(std::iter::once(text))?;
    }
    if let Some(g) = &guides.slope
        && let Some(ends) = clip_line(g, x_range, y_range)
    {
        chart
            .draw_series(DashedLineSeries::new(ends, 10, 6, GUIDE.stroke_width(2)))?
            .label(g.name.clone())
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 28, y)], GUIDE.stroke_width(2)));
    }
    Ok(())
}

/// The part of the slope guide's line inside the ranges, as its two ends; `None` when it
/// misses them.
fn clip_line(g: &SlopeGuide, x: &Range<f64>, y: &Range<f64>) -> Option<[(f64, f64); 2]> {
    let (x0, y0) = g.through;
    if !usable((x0, y0)) || !g.slope.is_finite() {
        return None;
    }
    // On log axes the line is ln y = ln y0 + k (ln x - ln x0): where it meets each y bound.
    let at_y = |v: f64| (x0.ln() + (v.ln() - y0.ln()) / g.slope).exp();
    let (mut lo, mut hi) = (x.start, x.end);
    if g.slope != 0.0 {
        let (a, b) = (at_y(y.start), at_y(y.end));
        lo = lo.max(a.min(b));
        hi = hi.min(a.max(b));
    } else if !y.contains(&y0) {
        return None;
    }
    let line = |v: f64| y0 * (v / x0).powf(g.slope);
    (lo < hi).then(|| [(lo, line(lo)), (hi, line(hi))])
}

#[cfg(test)]
mod tests {
    use super::ticks::{MAX_MAJOR_TICKS, TickFormat, superscript};
    use super::*;
    use crate::analysis::fit::log_log_slope;

    /// Points of the power law `c x^k`.
    fn power_law(c: f64, k: f64, xs: &[f64]) -> Vec<(f64, f64)> {
        xs.iter().map(|&x| (x, c * x.powf(k))).collect()
    }

    #[test]
    fn axis_range_covers_the_values_with_a_margin() {
        let r = axis_range([0.01, 10.0].into_iter());
        assert!(r.start < 0.01 && r.start > 0.005, "{r:?}");
        assert!(r.end > 10.0 && r.end < 20.0, "{r:?}");
        // A single value gets a decade around it.
        let r = axis_range([3.0].into_iter());
        assert!((r.end / r.start - 10.0).abs() < 1e-9, "{r:?}");
        assert!((r.start * r.end - 9.0).abs() < 1e-9, "{r:?}");
        assert_eq!(axis_range(std::iter::empty()), 1.0..10.0);
        // Extreme values stay finite and positive.
        let r = axis_range([f64::MIN_POSITIVE / 1e10, f64::MAX].into_iter());
        assert!(
            r.start > 0.0 && r.end.is_finite() && r.start < r.end,
            "{r:?}"
        );
    }

    #[test]
    fn ticks_on_log_axes() {
        let (major, minor) = log_ticks(&(0.05..200.0));
        assert_eq!(major.len(), 4);
        for (v, want) in major.iter().zip([0.1, 1.0, 10.0, 100.0]) {
            assert!((v / want - 1.0).abs() < 1e-12, "{major:?}");
        }
        assert!(minor.iter().any(|&v| (v - 0.05).abs() < 1e-12));
        assert!(minor.iter().any(|&v| (v - 200.0).abs() < 1e-9));
        assert_eq!(minor.len(), 5 + 3 * 8 + 1);

        // Fewer than three powers of ten: 1-2-5 ticks.
        let labels = |major: &[f64]| -> Vec<String> {
            let format = tick_format(major);
            major.iter().map(|&v| tick_label(v, format)).collect()
        };
        let (major, minor) = log_ticks(&(0.031..0.29));
        assert_eq!(labels(&major), ["0.05", "0.1", "0.2"]);
        assert_eq!(minor.len(), 5);
        let (major, minor) = log_ticks(&(0.0081..0.7));
        assert_eq!(
            labels(&major),
            ["0.01", "0.02", "0.05", "0.1", "0.2", "0.5"]
        );
        assert_eq!(minor.len(), 1 + 6 + 4);
        let (major, _) = log_ticks(&(4e-6..2e-4));
        assert_eq!(
            labels(&major),
            ["5×10⁻⁶", "10⁻⁵", "2×10⁻⁵", "5×10⁻⁵", "10⁻⁴", "2×10⁻⁴"]
        );

        // Very wide ranges label at most MAX_MAJOR_TICKS powers of ten.
        let (major, minor) = log_ticks(&(1e-200..1e200));
        assert!(
            major.len() <= MAX_MAJOR_TICKS && major.len() >= 5,
            "{major:?}"
        );
        assert_eq!(major.len() + minor.len(), 401);
    }

    #[test]
    fn tick_labels() {
        assert_eq!(tick_format(&[0.001, 0.01, 10_000.0]), TickFormat::Plain);
        assert_eq!(tick_format(&[1e-4, 1e-3]), TickFormat::Power);
        assert_eq!(tick_format(&[1.0, 1e5]), TickFormat::Power);
        assert_eq!(tick_label(0.001, TickFormat::Plain), "0.001");
        assert_eq!(tick_label(2.0 * 10f64.powi(-3), TickFormat::Plain), "0.002");
        assert_eq!(tick_label(1.0, TickFormat::Plain), "1");
        assert_eq!(tick_label(5000.0, TickFormat::Plain), "5000");
        assert_eq!(tick_label(10f64.powi(-4), TickFormat::Power), "10⁻⁴");
        assert_eq!(tick_label(10f64.powi(12), TickFormat::Power), "10¹²");
        assert_eq!(tick_label(1.0, TickFormat::Power), "10⁰");
        assert_eq!(tick_label(2.0 * 10f64.powi(6), TickFormat::Power), "2×10⁶");
        assert_eq!(superscript(-1234567890), "⁻¹²³⁴⁵⁶⁷⁸⁹⁰");
    }

    #[test]
    fn legend_goes_where_the_data_is_not() {
        let area = (800, 600);
        let legend = (200, 80);
        // Falling line from upper left to lower right: upper right is free.
        let falling = vec![(10, 10), (400, 300), (790, 590)];
        assert_eq!(legend_corner(&[falling], area, legend), 0);
        // Rising line from lower left to upper right: upper left is free too,
        // but lower right comes after it in preference.
        let rising = vec![(10, 590), (400, 300), (790, 10)];
        assert_eq!(
            legend_corner(std::slice::from_ref(&rising), area, legend),
            2
        );
        // Rising line plus a point in the upper left: lower right.
        assert_eq!(legend_corner(&[rising, vec![(50, 30)]], area, legend), 3);
        // No data: the first choice.
        assert_eq!(legend_corner(&[], area, legend), 0);
    }

    #[test]
    fn legend_labels() {
        let mut s = Series {
            name: "independent".into(),
            points: vec![],
            slope: Some(-0.9812),
            bars: Vec::new(),
        };
        assert_eq!(legend_label(&s), "independent (slope -0.98)");
        s.slope = None;
        assert_eq!(legend_label(&s), "independent");
        s.slope = Some(f64::NAN);
        assert_eq!(legend_label(&s), "independent");
        s.slope = Some(-0.001);
        assert_eq!(legend_label(&s), "independent (slope 0.00)");
        s.slope = Some(1.5);
        assert_eq!(legend_label(&s), "independent (slope 1.50)");
    }

    fn two_series() -> Vec<Series> {
        let times = [0.01, 0.02, 0.04, 0.08, 0.16, 0.32, 0.64];
        let independent = power_law(0.004, -0.5, &times);
        let stratified = power_law(0.0004, -0.98, &times);
        vec![
            Series {
                name: "independent".into(),
                slope: log_log_slope(&independent),
                bars: Vec::new(),
                points: independent,
            },
            Series {
                name: "stratified".into(),
                slope: log_log_slope(&stratified),
                bars: Vec::new(),
                points: stratified,
            },
        ]
    }

    fn count_pixels(image: &image::RgbImage, colour: RGBColor) -> usize {
        image
            .pixels()
            .filter(|p| p.0 == [colour.0, colour.1, colour.2])
            .count()
    }

    #[test]
    fn png_plot_decodes_with_each_series_drawn() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.PNG");
        write_plot(
            &path,
            "Convergence",
            "time (s)",
            "RMSE",
            &two_series(),
            &Guides::default(),
        )
        .unwrap();
        let image = image::open(&path).unwrap().to_rgb8();
        assert_eq!(image.dimensions(), (1000, 700));

        // The same plot with no points draws each colour only in the legend key.
        let mut no_points = two_series();
        for s in &mut no_points {
            s.points.clear();
        }
        let empty_path = dir.path().join("empty.png");
        write_plot(
            &empty_path,
            "Convergence",
            "time (s)",
            "RMSE",
            &no_points,
            &Guides::default(),
        )
        .unwrap();
        let empty = image::open(&empty_path).unwrap().to_rgb8();
        assert_eq!(empty.dimensions(), (1000, 700));

        for colour in &PALETTE[..2] {
            let with_data = count_pixels(&image, *colour);
            let legend_only = count_pixels(&empty, *colour);
            assert!(legend_only > 20, "{colour:?}: {legend_only}");
            // Seven markers and the lines joining them.
            assert!(
                with_data > legend_only + 7 * 40,
                "{colour:?}: {with_data} vs {legend_only}"
            );
        }
        assert_eq!(count_pixels(&image, PALETTE[2]), 0);
    }

    #[test]
    fn png_text_is_rendered_with_the_embedded_font() {
        // Dark pixels where the title goes: centred, above the plotting area.
        let dark_pixels_in_title_area = |title: &str| {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("plot.png");
            write_plot(
                &path,
                title,
                "time (s)",
                "RMSE",
                &two_series(),
                &Guides::default(),
            )
            .unwrap();
            let image = image::open(&path).unwrap().to_rgb8();
            image
                .enumerate_pixels()
                .filter(|&(x, y, p)| {
                    (250..650).contains(&x) && y < 40 && p.0.iter().all(|&c| c < 100)
                })
                .count()
        };
        assert_eq!(dark_pixels_in_title_area(""), 0);
        assert!(dark_pixels_in_title_area("Convergence of samplers") > 300);
    }

    #[test]
    fn svg_plot_is_self_contained_with_legend_text() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.Svg");
        let mut series = two_series();
        series[0].slope = Some(-0.98);
        series.push(Series {
            name: "a <b> & c".into(),
            points: vec![(0.05, 0.01)],
            slope: None,
            bars: Vec::new(),
        });
        write_plot(
            &path,
            "Convergence",
            "time (s)",
            "RMSE",
            &series,
            &Guides::default(),
        )
        .unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..100]);
        assert!(svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains(r#"width="1000" height="700""#));
        assert!(svg.contains("independent (slope -0.98)"));
        let stratified = format!("stratified (slope {:.2})", series[1].slope.unwrap());
        assert_eq!(stratified, "stratified (slope -0.98)");
        assert!(svg.contains(&stratified));
        assert!(svg.contains("\na &lt;b&gt; &amp; c\n"));
        assert!(svg.contains("Convergence") && svg.contains("time (s)") && svg.contains("RMSE"));
        for external in ["<image", "href", "url(", "@import"] {
            assert!(!svg.contains(external), "{external}");
        }
    }

    #[test]
    fn bars_levels_and_the_slope_guide_are_drawn() {
        let dir = tempfile::tempdir().unwrap();
        let grey = |image: &image::RgbImage| count_pixels(image, GUIDE);
        let draw = |name: &str, series: &[Series], guides: &Guides| {
            let path = dir.path().join(name);
            write_plot(&path, "t", "x", "y", series, guides).unwrap();
            image::open(&path).unwrap().to_rgb8()
        };
        let plain = draw("plain.png", &two_series(), &Guides::default());
        assert_eq!(grey(&plain), 0);
        let guides = Guides {
            levels: vec![(0.0004, "2%".into()), (-1.0, "unusable".into())],
            slope: Some(SlopeGuide {
                through: (0.04, 0.01),
                slope: -1.0,
                name: "ideal (slope -1)".into(),
            }),
        };
        let guided = draw("guided.png", &two_series(), &guides);
        // A dotted level across the plot and a dashed guide: hundreds of grey pixels.
        assert!(grey(&guided) > 300, "{}", grey(&guided));
        // The guide's line clipped to the plot: a guide far outside draws no line.
        let far = SlopeGuide {
            through: (1e6, 1e6),
            slope: 0.0,
            name: "far".into(),
        };
        assert_eq!(clip_line(&far, &(1.0..10.0), &(1.0..10.0)), None);
        let ends = clip_line(&guides.slope.clone().unwrap(), &(0.01..1.0), &(1e-3..1e-2)).unwrap();
        // y = 4e-4 / x meets y = 1e-2 at x = 0.04 and y = 1e-3 at x = 0.4.
        assert!((ends[0].0 - 0.04).abs() < 1e-12 && (ends[1].0 - 0.4).abs() < 1e-12);
        // Bars add the series' colour around the markers.
        let mut barred = two_series();
        barred[0].bars = barred[0]
            .points
            .iter()
            .map(|&(x, y)| Bar {
                x: (x * 0.8, x * 1.25),
                y: (y * 0.5, y * 2.0),
            })
            .collect();
        // A bar whose low end is below zero is drawn to the axis.
        barred[0].bars[0].y.0 = -1.0;
        let with_bars = draw("bars.png", &barred, &Guides::default());
        let colour = PALETTE[0];
        assert!(count_pixels(&with_bars, colour) > count_pixels(&plain, colour) + 7 * 20);
    }

    #[test]
    fn unknown_extensions_are_errors_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["plot.jpg", "plot", "plot.png.txt", "png"] {
            let path = dir.path().join(name);
            let err =
                write_plot(&path, "t", "x", "y", &two_series(), &Guides::default()).unwrap_err();
            assert!(err.contains(&path.display().to_string()), "{err}");
            assert!(!path.exists());
        }
    }

    #[test]
    fn io_errors_name_the_path() {
        let dir = tempfile::tempdir().unwrap();
        // A folder that cannot be made: its name is taken by a file.
        std::fs::write(dir.path().join("blocker"), b"a file").unwrap();
        for name in ["blocker/plot.png", "blocker/plot.svg"] {
            let path = dir.path().join(name);
            let err =
                write_plot(&path, "t", "x", "y", &two_series(), &Guides::default()).unwrap_err();
            assert!(err.contains(&path.display().to_string()), "{err}");
        }
    }

    #[test]
    fn plots_without_usable_points_are_still_written() {
        let dir = tempfile::tempdir().unwrap();
        let unusable = vec![Series {
            name: "broken".into(),
            points: vec![
                (0.0, 1.0),
                (-1.0, 1.0),
                (1.0, 0.0),
                (f64::NAN, 1.0),
                (1.0, f64::INFINITY),
            ],
            slope: None,
            bars: Vec::new(),
        }];
        for (name, series) in [("none", Vec::new()), ("unusable", unusable)] {
            for ext in ["png", "svg"] {
                let path = dir.path().join(format!("{name}.{ext}"));
                write_plot(&path, "", "", "", &series, &Guides::default()).unwrap();
                if ext == "png" {
                    let image = image::open(&path).unwrap();
                    assert_eq!((image.width(), image.height()), (1000, 700));
                } else {
                    let svg = std::fs::read_to_string(&path).unwrap();
                    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
                }
            }
        }
    }

    #[test]
    fn odd_data_does_not_panic() {
        let dir = tempfile::tempdir().unwrap();
        let series = vec![
            Series {
                name: "extreme".into(),
                points: vec![(f64::MIN_POSITIVE / 1e10, f64::MAX), (f64::MAX, 1e-300)],
                slope: Some(f64::INFINITY),
                bars: Vec::new(),
            },
            Series {
                name: "one point".into(),
                points: vec![(1.0, 1.0)],
                slope: None,
                bars: Vec::new(),
            },
            Series {
                name: String::new(),
                points: vec![(2.0, 3.0); 3],
                slope: Some(0.0),
                bars: Vec::new(),
            },
        ];
        for ext in ["png", "svg"] {
            let path = dir.path().join(format!("odd.{ext}"));
            write_plot(&path, "odd", "x", "y", &series, &Guides::default()).unwrap();
        }
        // Many series cycle through the colours and shapes.
        let many: Vec<Series> = (0..13)
            .map(|i| Series {
                name: format!("s{i}"),
                points: power_law(1.0 + f64::from(i), -0.5, &[1.0, 10.0]),
                slope: None,
                bars: Vec::new(),
            })
            .collect();
        write_plot(
            &dir.path().join("many.png"),
            "many",
            "x",
            "y",
            &many,
            &Guides::default(),
        )
        .unwrap();
    }
}
