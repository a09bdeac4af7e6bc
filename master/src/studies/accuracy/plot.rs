//! Pareto plots of the study: trace time against RMSE on log–log axes, every configuration a
//! point, the Pareto front a line, the default configuration marked. Written as SVG and PNG with
//! axis labels, a legend (what each colour and mark is) and a caption, laid out with the font
//! built into the binary ([`crate::plot::font_ready`]).

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// What kind of configuration a point is, for its colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Series {
    /// Single precision, one sample.
    F32OneSample,
    /// Double precision, one sample.
    F64OneSample,
    /// Four samples per pixel.
    FourSamples,
}

/// One point of the plot.
#[derive(Clone, Copy, Debug)]
pub struct PlotPoint {
    /// Trace seconds.
    pub time: f64,
    /// RMSE against the reference.
    pub rmse: f64,
    /// Its series.
    pub series: Series,
    /// True for the renderer's default configuration.
    pub is_default: bool,
    /// True when on the Pareto front.
    pub on_front: bool,
}

const GREY: RGBColor = RGBColor(150, 150, 150);
const GREEN2: RGBColor = RGBColor(30, 150, 60);
const ORANGE: RGBColor = RGBColor(230, 130, 0);
const FRONT: RGBColor = RGBColor(200, 30, 30);
const DEFAULT: RGBColor = RGBColor(20, 60, 220);

impl Series {
    /// The legend's words for it.
    pub fn label(self) -> &'static str {
        match self {
            Series::F32OneSample => "f32, 1 sample per pixel",
            Series::F64OneSample => "f64, 1 sample per pixel",
            Series::FourSamples => "4 samples per pixel",
        }
    }
}

fn colour(s: Series) -> RGBColor {
    match s {
        Series::F32OneSample => GREY,
        Series::F64OneSample => GREEN2,
        Series::FourSamples => ORANGE,
    }
}

/// Log-axis bounds around the data, padded, on whole powers of ten.
fn bounds(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for x in v.filter(|x| *x > 0.0 && x.is_finite()) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !lo.is_finite() {
        return (1e-3, 1.0);
    }
    (
        10f64.powf((lo * 0.8).log10().floor()),
        10f64.powf((hi * 1.25).log10().ceil()),
    )
}

fn plotting_error<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plotting failed: {e:?}")
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    points: &[PlotPoint],
    text: bool,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(plotting_error)?;
    // Zero errors cannot sit on a log axis: show them at the axis floor.
    let (x0, x1) = bounds(points.iter().map(|p| p.time));
    let (y0, y1) = bounds(points.iter().map(|p| p.rmse));
    let pos = |p: &PlotPoint| (p.time.max(x0), p.rmse.max(y0));
    let mut builder = ChartBuilder::on(&root);
    builder.margin(16);
    if text {
        builder
            .caption(title, ("sans-serif", 20))
            .x_label_area_size(45)
            .y_label_area_size(70);
    }
    let mut chart = builder
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(plotting_error)?;
    if text {
        chart
            .configure_mesh()
            .x_desc("trace time (s, log)")
            .y_desc("RMSE against the reference (linear RGB in [0, 1], log)")
            .draw()
            .map_err(plotting_error)?;
    } else {
        // Grid lines at powers of ten, and a frame.
        let light = RGBColor(225, 225, 225);
        let mut e = x0;
        while e <= x1 * 1.0001 {
            chart
                .draw_series(LineSeries::new([(e, y0), (e, y1)], &light))
                .map_err(plotting_error)?;
            e *= 10.0;
        }
        let mut e = y0;
        while e <= y1 * 1.0001 {
            chart
                .draw_series(LineSeries::new([(x0, e), (x1, e)], &light))
                .map_err(plotting_error)?;
            e *= 10.0;
        }
        chart
            .draw_series(LineSeries::new(
                [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)],
                &BLACK,
            ))
            .map_err(plotting_error)?;
    }
    for s in [
        Series::F32OneSample,
        Series::F64OneSample,
        Series::FourSamples,
    ] {
        let c = colour(s);
        let anno = chart
            .draw_series(
                points
                    .iter()
                    .filter(|p| p.series == s)
                    .map(|p| Circle::new(pos(p), 4, c.filled())),
            )
            .map_err(plotting_error)?;
        if text {
            anno.label(s.label())
                .legend(move |(x, y)| Circle::new((x + 8, y), 4, c.filled()));
        }
    }
    let mut front: Vec<(f64, f64)> = points.iter().filter(|p| p.on_front).map(pos).collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let anno = chart
        .draw_series(LineSeries::new(
            front.iter().copied(),
            FRONT.stroke_width(2),
        ))
        .map_err(plotting_error)?;
    if text {
        anno.label("Pareto front (no faster point is more accurate)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], FRONT.stroke_width(2)));
    }
    chart
        .draw_series(
            front
                .iter()
                .map(|&q| Circle::new(q, 5, FRONT.stroke_width(2))),
        )
        .map_err(plotting_error)?;
    let anno = chart
        .draw_series(
            points
                .iter()
                .filter(|p| p.is_default)
                .map(|p| Circle::new(pos(p), 8, DEFAULT.stroke_width(3))),
        )
        .map_err(plotting_error)?;
    if text {
        anno.label("default: cut-off 0.001, depth 5, f32, 1 sample")
            .legend(|(x, y)| Circle::new((x + 8, y), 6, DEFAULT.stroke_width(3)));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plotting_error)?;
    }
    root.present().map_err(plotting_error)?;
    Ok(())
}

/// Writes `stem.svg` and `stem.png` for one scene.
pub fn write(stem: &Path, title: &str, points: &[PlotPoint]) -> anyhow::Result<()> {
    // Both backends lay text out with the registered font; without one, draw no text.
    let text = crate::plot::font_ready();
    let svg = stem.with_extension("svg");
    draw(
        SVGBackend::new(&svg, (800, 600)).into_drawing_area(),
        title,
        points,
        text,
    )?;
    let png = stem.with_extension("png");
    crate::plot::save_png(&png, (800, 600), |root| draw(root, title, points, text))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_cover_the_data_on_decades() {
        let (lo, hi) = bounds([0.003, 0.2, 0.0, f64::NAN].into_iter());
        assert!(lo <= 0.003 && hi >= 0.2);
        assert_eq!(lo, 1e-3);
        assert_eq!(hi, 1.0);
    }

    #[test]
    fn writes_both_files() {
        let dir = tempfile::tempdir().expect("temp dir");
        let pts = [
            PlotPoint {
                time: 0.1,
                rmse: 0.02,
                series: Series::F32OneSample,
                is_default: true,
                on_front: true,
            },
            PlotPoint {
                time: 0.4,
                rmse: 0.0,
                series: Series::FourSamples,
                is_default: false,
                on_front: true,
            },
            PlotPoint {
                time: 0.2,
                rmse: 0.03,
                series: Series::F64OneSample,
                is_default: false,
                on_front: false,
            },
        ];
        let stem = dir.path().join("pareto-test");
        write(&stem, "test", &pts).expect("plots");
        let svg = std::fs::read_to_string(stem.with_extension("svg")).expect("svg");
        assert!(svg.contains("<svg"));
        if crate::plot::font_ready() {
            assert!(svg.contains("RMSE"));
        }
        let png = image::open(stem.with_extension("png")).expect("png decodes");
        assert_eq!((png.width(), png.height()), (800, 600));
    }
}
