//! Line and scatter charts for the studies, written as SVG and PNG with plotters. Text needs a
//! font to be laid out: DejaVu Sans is built into the binary (`master/assets/`, with its
//! licence) and registered once, so titles, axes and legends are drawn on every machine,
//! whatever fonts it has installed.
//!
//! A chart of efficiencies carries a [`Reference`]: a dashed line at the ideal (1), and a note
//! under the chart when some value lies above it, saying why that can happen. A y axis that does
//! not start at zero says so in its label, so a small spread does not look dramatic.
//!
//! PNGs are drawn into an RGB buffer and encoded with the workspace's `image` ([`save_png`],
//! which every plot uses): plotters' own encoder would pull in a second, older `image`.

use anyhow::Context;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// One line (or point set) of a chart.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
    /// Draw a connecting line (else points only).
    pub line: bool,
}

/// A chart description.
#[derive(Clone, Debug)]
pub struct Chart {
    /// Caption.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Data.
    pub series: Vec<Series>,
    /// Logarithmic x axis (base 2 ticks are labelled as numbers).
    pub log_x: bool,
    /// Fixed y range; `None`: from the data (and the reference line, if any).
    pub y_range: Option<(f64, f64)>,
    /// A horizontal reference line (the ideal), if any.
    pub reference: Option<Reference>,
}

/// A horizontal line the data is read against, with what a value above it means.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Where the line is.
    pub y: f64,
    /// Its legend label.
    pub label: String,
    /// The note printed under the chart when a value lies above the line.
    pub above: String,
}

impl Reference {
    /// The ideal parallel efficiency, 1, and why a measured value can exceed it.
    pub fn ideal_efficiency() -> Reference {
        Reference {
            y: 1.0,
            label: "ideal (1)".into(),
            above: "Above 1: superlinear (each thread's share stays warmer in its caches) or \
                    timing noise."
                .into(),
        }
    }
}

/// A y range from zero to a little above both the data and `ideal`, for efficiency charts.
pub fn range_from_zero(series: &[Series], ideal: f64) -> (f64, f64) {
    let top = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .filter(|y| y.is_finite())
        .fold(ideal, f64::max);
    (0.0, top * 1.08)
}

/// The y axis's label: the chart's, plus a warning when the axis does not start at zero.
pub fn y_label(chart: &Chart, y0: f64) -> String {
    if y0 > 0.0 {
        format!("{} (axis starts at {y0:.2}, not 0)", chart.y_label)
    } else {
        chart.y_label.clone()
    }
}

/// The note under the chart: the reference's explanation when some value lies above it.
pub fn note(chart: &Chart) -> Option<&str> {
    let r = chart.reference.as_ref()?;
    let above = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .any(|&(_, y)| y.is_finite() && y > r.y);
    above.then_some(r.above.as_str())
}

/// DejaVu Sans, built into the binary: the text of every plot.
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Registers the built-in font with plotters once. True unless plotters refused it, which
/// cannot happen with the font built in (a test checks it); a plot drawn without it would
/// have no text, so that is said on stderr rather than left silent.
pub fn font_ready() -> bool {
    static READY: OnceLock<bool> = OnceLock::new();
    *READY.get_or_init(|| {
        let ok = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).is_ok();
        if !ok {
            crate::errln!("parrt: warning: the plots' font could not be loaded; they have no text");
        }
        ok
    })
}

fn bounds(chart: &Chart) -> ((f64, f64), (f64, f64)) {
    let pts = chart.series.iter().flat_map(|s| s.points.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        if x.is_finite() && y.is_finite() {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if let Some(r) = &chart.reference {
        y0 = y0.min(r.y);
        y1 = y1.max(r.y);
    }
    if x0 == x1 {
        x1 = x0 + 1.0;
    }
    if y0 == y1 {
        y1 = y0 + 1.0;
    }
    let ypad = (y1 - y0) * 0.05;
    let y = chart.y_range.unwrap_or((y0 - ypad, y1 + ypad));
    ((x0, x1), y)
}

/// The series' colours, in order (then again from the first).
const COLORS: [RGBColor; 8] = [
    RED,
    BLUE,
    GREEN,
    MAGENTA,
    CYAN,
    BLACK,
    RGBColor(230, 140, 0),
    RGBColor(120, 60, 160),
];

/// The chart's note, if any (and text can be drawn), in a strip of its own under the chart:
/// returns the area left for the chart.
fn with_note<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
    text: bool,
) -> anyhow::Result<DrawingArea<DB, plotters::coord::Shift>>
where
    DB::ErrorType: 'static,
{
    Ok(match note(chart).filter(|_| text) {
        Some(n) => {
            let (_, h) = root.dim_in_pixel();
            let (upper, lower) = root.split_vertically(h.saturating_sub(28));
            lower
                .draw(&Text::new(n.to_string(), (16, 4), ("sans-serif", 14)))
                .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            upper
        }
        None => root,
    })
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let text = font_ready();
    root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let ((x0, x1), (y0, y1)) = bounds(chart);
    let y_desc = y_label(chart, y0);
    let root = with_note(root, chart, text)?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .margin(16)
        .x_label_area_size(if text { 40 } else { 0 })
        .y_label_area_size(if text { 60 } else { 0 });
    if text {
        builder.caption(&chart.title, ("sans-serif", 20));
    }
    macro_rules! body {
        ($ctx:expr, $map:expr) => {{
            let mut ctx = $ctx;
            if text {
                let mut mesh = ctx.configure_mesh();
                mesh.x_desc(chart.x_label.as_str()).y_desc(y_desc.as_str());
                if chart.log_x {
                    mesh.x_label_formatter(&tick);
                }
                mesh.draw().map_err(|e| anyhow::anyhow!("{e:?}"))?;
            } else {
                ctx.configure_mesh()
                    .disable_x_mesh()
                    .disable_y_mesh()
                    .x_labels(0)
                    .y_labels(0)
                    .draw()
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            }
            for (i, s) in chart.series.iter().enumerate() {
                let color = COLORS[i % COLORS.len()];
                let pts: Vec<(f64, f64)> = s.points.iter().map($map).collect();
                if s.line {
                    let anno = ctx
                        .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
                    if text {
                        anno.label(s.label.as_str()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                        });
                    }
                }
                let anno = ctx
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
                if text && !s.line {
                    anno.label(s.label.as_str())
                        .legend(move |(x, y)| Circle::new((x + 9, y), 3, color.filled()));
                }
            }
            // Over the data, so the ideal shows where lines cross it.
            if let Some(r) = &chart.reference {
                let xs = ctx.x_range();
                let line = [(xs.start, r.y), (xs.end, r.y)];
                let style = BLACK.mix(0.7).stroke_width(1);
                let anno = ctx
                    .draw_series(DashedLineSeries::new(line.iter().map($map), 6, 4, style))
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
                if text {
                    anno.label(r.label.as_str()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], BLACK.mix(0.7))
                    });
                }
            }
            if text {
                ctx.configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .position(SeriesLabelPosition::LowerRight)
                    .draw()
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
            }
        }};
    }
    if chart.log_x && x0 > 0.0 {
        // Ticks at the data's x values (tile sizes, thread counts): a log axis over less than
        // a decade has no power of ten to label otherwise.
        let ctx = builder
            .build_cartesian_2d(
                (x0 * 0.9..x1 * 1.1)
                    .log_scale()
                    .with_key_points(x_values(chart)),
                y0..y1,
            )
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        body!(ctx, |&p: &(f64, f64)| p);
    } else {
        let pad = (x1 - x0) * 0.05;
        let ctx = builder
            .build_cartesian_2d(x0 - pad..x1 + pad, y0..y1)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        body!(ctx, |&p: &(f64, f64)| p);
    }
    root.present().map_err(|e| anyhow::anyhow!("{e:?}"))?;
    Ok(())
}

/// The distinct finite x values of the chart's points, in order.
fn x_values(chart: &Chart) -> Vec<f64> {
    let mut xs: Vec<f64> = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .filter(|x| x.is_finite())
        .collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    xs
}

/// A tick label: whole numbers without a fraction (`16`, not `16.0`).
fn tick(x: &f64) -> String {
    if x.fract() == 0.0 && x.abs() < 1e15 {
        format!("{}", *x as i64)
    } else {
        format!("{x}")
    }
}

/// Writes the chart as SVG and PNG (800×500).
pub fn save_chart(chart: &Chart, svg: &Path, png: &Path) -> anyhow::Result<()> {
    draw(SVGBackend::new(svg, (800, 500)).into_drawing_area(), chart)
        .with_context(|| format!("cannot draw {}", svg.display()))?;
    save_png(png, (800, 500), |root| draw(root, chart))
        .with_context(|| format!("cannot draw {}", png.display()))
}

/// Lets `draw` paint a `size` (width, height) bitmap, then writes it to `path` as an 8-bit RGB
/// PNG.
pub fn save_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let (w, h) = size;
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    // The backend borrows the buffer until `draw` returns (and has presented it).
    draw(BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area())?;
    image::save_buffer_with_format(
        path,
        &rgb,
        w,
        h,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart(points: Vec<(f64, f64)>, reference: Option<Reference>) -> Chart {
        Chart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "efficiency".into(),
            series: vec![Series {
                label: "s".into(),
                points,
                line: true,
            }],
            log_x: false,
            y_range: None,
            reference,
        }
    }

    #[test]
    fn the_ideal_is_inside_the_range_and_a_value_above_it_is_explained() {
        let below = chart(
            vec![(8.0, 0.8), (16.0, 0.9)],
            Some(Reference::ideal_efficiency()),
        );
        let ((_, _), (_, y1)) = bounds(&below);
        assert!(y1 >= 1.0, "the ideal line is drawn: {y1}");
        assert_eq!(note(&below), None);
        let above = chart(
            vec![(8.0, 0.9), (16.0, 1.06)],
            Some(Reference::ideal_efficiency()),
        );
        assert!(note(&above).is_some_and(|n| n.contains("superlinear")));
        assert_eq!(note(&chart(vec![(8.0, 1.2)], None)), None);
    }

    #[test]
    fn an_axis_not_from_zero_says_so() {
        let c = chart(vec![(8.0, 0.8), (16.0, 0.9)], None);
        let ((_, _), (y0, _)) = bounds(&c);
        assert!(y0 > 0.0);
        assert!(y_label(&c, y0).contains("not 0"), "{}", y_label(&c, y0));
        let (z0, z1) = range_from_zero(&c.series, 1.0);
        assert_eq!(z0, 0.0);
        assert!(z1 > 1.0);
        assert_eq!(y_label(&c, z0), "efficiency");
    }

    #[test]
    fn charts_with_a_note_are_drawn() {
        let dir = tempfile::tempdir().expect("temp dir");
        let c = chart(
            vec![(8.0, 0.9), (16.0, 1.06)],
            Some(Reference::ideal_efficiency()),
        );
        let (svg, png) = (dir.path().join("c.svg"), dir.path().join("c.png"));
        save_chart(&c, &svg, &png).expect("draws");
        let text = std::fs::read_to_string(&svg).expect("svg");
        assert!(text.contains("superlinear"), "the note is in the SVG");
        assert!(text.contains("ideal (1)"));
        assert!(std::fs::metadata(&png).expect("png").len() > 0);
    }

    /// The font is built in: every chart has its title, axis labels, legend and tick labels,
    /// in the SVG as text and in the PNG as ink, on any machine. A log axis over less than a
    /// decade (tile sizes 16 and 64) is labelled at the data's x values.
    #[test]
    fn every_chart_has_its_text_and_a_short_log_axis_its_ticks() {
        assert!(font_ready(), "the built-in font registers");
        let dir = tempfile::tempdir().expect("temp dir");
        let mut c = chart(vec![(16.0, 0.7), (64.0, 0.9)], None);
        c.title = "The Title".into();
        c.x_label = "tile edge".into();
        c.log_x = true;
        let (svg, png) = (dir.path().join("c.svg"), dir.path().join("c.png"));
        save_chart(&c, &svg, &png).expect("draws");
        // plotters writes each text on a line of its own inside its element.
        let text = std::fs::read_to_string(&svg)
            .expect("svg")
            .replace('\n', "");
        for want in [
            "The Title",
            "tile edge",
            "efficiency",
            ">s<",
            ">16<",
            ">64<",
        ] {
            assert!(text.contains(want), "the SVG lacks {want}: {text}");
        }
        // Ink in the PNG's caption strip (the title), where a chart without text is white.
        let img = image::open(&png).expect("png").to_rgb8();
        let inked = (16..40)
            .flat_map(|y| (300..500).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0.iter().any(|&v| v < 128))
            .count();
        assert!(inked > 50, "{inked} dark pixels where the title goes");
    }
}
