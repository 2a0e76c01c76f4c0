//! The chart kinds: per-measurement errors, histograms, training curve, position scatter.

use super::{Chart, DrawResult};
use crate::neural::train::Phase2;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// Series colours, in order (Tableau's ten): `case-d` draws eight series in one chart, and
/// with six its first two shared their colours with the last two.
pub const COLOURS: [RGBColor; 10] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

fn font(size: u32) -> TextStyle<'static> {
    ("sans-serif", size).into_font().into()
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    c: &mut ChartContext<'a, DB, CT>,
) -> DrawResult<DB> {
    c.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(font(15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
}

/// A tick label: few digits, no float noise.
fn short(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e4).contains(&a) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    }
}

/// Values spanning more than this ratio of means get a logarithmic axis.
const LOG_RATIO: f64 = 20.0;

/// Named series of values with one unit.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend name, e.g. "nominal" or "identified".
    pub label: String,
    /// The data file's line of each value (of a pair's second row): the x of per-measurement
    /// plots, the line the commands' messages name.
    pub rows: Vec<usize>,
    /// The values, in the unit of the chart that shows them (e.g. mm or deg).
    pub values: Vec<f64>,
}

/// Whether the series' means differ so much that a linear axis would hide the small ones.
fn wants_log(series: &[Series]) -> bool {
    let means: Vec<f64> = series
        .iter()
        .map(|s| mean(&s.values))
        .filter(|m| *m > 0.0)
        .collect();
    let (lo, hi) = means
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), m| (a.min(*m), b.max(*m)));
    means.len() > 1 && hi / lo > LOG_RATIO
}

/// Error of every measurement, one line per series (thesis Figs. 6.1, 6.3, 6.5).
pub struct ErrorSeries {
    /// Title drawn above the chart.
    pub title: String,
    /// Axis title with unit, e.g. "position error (mm)".
    pub y_label: String,
    /// The x axis's title, e.g. "line in the data file".
    pub x_label: String,
    /// Unit for the legend's means, e.g. "mm".
    pub unit: String,
    /// One line per series.
    pub series: Vec<Series>,
}

impl Chart for ErrorSeries {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let n = self
            .series
            .iter()
            .filter_map(|s| s.rows.last().copied())
            .max()
            .unwrap_or(0)
            .max(1);
        let all = self.series.iter().flat_map(|s| s.values.iter().copied());
        let hi = all.clone().fold(0.0f64, f64::max).max(1e-12);
        let x = 0.5..n as f64 + 0.5;
        let mut b = ChartBuilder::on(root);
        b.caption(&self.title, font(22))
            .margin(12)
            .x_label_area_size(50)
            .y_label_area_size(80);
        if wants_log(&self.series) {
            let lo = all
                .filter(|v| *v > 0.0)
                .fold(f64::INFINITY, f64::min)
                .min(hi)
                * 0.8;
            // Headroom above the data for the legend.
            let top = hi * (hi / lo).powf(0.35);
            let mut c = b.build_cartesian_2d(x, (lo..top).log_scale())?;
            c.configure_mesh()
                .x_desc(self.x_label.as_str())
                .x_label_formatter(&|x| format!("{x:.0}"))
                .y_desc(format!("{} (log scale)", self.y_label))
                .y_label_formatter(&|v| short(*v))
                .axis_desc_style(font(17))
                .label_style(font(14))
                .draw()?;
            self.lines(&mut c, lo)
        } else {
            let mut c = b.build_cartesian_2d(x, 0.0..hi * 1.4)?;
            c.configure_mesh()
                .x_desc(self.x_label.as_str())
                .x_label_formatter(&|x| format!("{x:.0}"))
                .y_desc(self.y_label.as_str())
                .axis_desc_style(font(17))
                .label_style(font(14))
                .draw()?;
            self.lines(&mut c, f64::NEG_INFINITY)
        }
    }
}

impl ErrorSeries {
    /// Draws every series (values below `floor` at `floor`, for a log axis) and the legend.
    fn lines<'a, DB, Y>(
        &self,
        c: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
        floor: f64,
    ) -> DrawResult<DB>
    where
        DB: DrawingBackend + 'a,
        Y: Ranged<ValueType = f64>,
    {
        for (k, s) in self.series.iter().enumerate() {
            let col = COLOURS[k % COLOURS.len()];
            let pts = s
                .rows
                .iter()
                .zip(&s.values)
                .map(|(i, v)| (*i as f64, v.max(floor)));
            c.draw_series(LineSeries::new(pts.clone(), col.stroke_width(1)))?
                .label(format!(
                    "{}: mean {:.4} {}",
                    s.label,
                    mean(&s.values),
                    self.unit
                ))
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, col.filled()));
            c.draw_series(pts.map(|p| Circle::new(p, 2, col.filled())))?;
        }
        legend(c)
    }
}

/// One histogram panel per series, each on its own range (before and after often differ by
/// orders of magnitude).
pub struct Histograms {
    /// Title drawn above the panels.
    pub title: String,
    /// Axis title with unit, e.g. "position error (mm)".
    pub x_label: String,
    /// Unit of the values, e.g. "mm".
    pub unit: String,
    /// One panel per series.
    pub series: Vec<Series>,
}

/// Bins of a histogram panel.
const BINS: usize = 20;

/// A histogram panel's bins: [`BINS`] of equal width from 0 to `hi`. The range ends at the
/// largest value, unless that is more than [`OUTLIER_SPAN`] times the 99th percentile (one
/// value below the largest however few, from [`MIN_CLIPPED`] values on): one outlier of 60
/// mm among errors of 0.3 mm put 299 of 300 rows in the first bin. The range then ends at that percentile, the last bin also counts the values above it,
/// and `beyond` says how many and how far (count, largest value). Values that are not finite
/// are not counted (errors are finite; a chart draws what it can).
struct Bins {
    hi: f64,
    counts: [usize; BINS],
    beyond: Option<(usize, f64)>,
}

/// How many times the 99th percentile the largest value may be before the range stops there.
const OUTLIER_SPAN: f64 = 2.0;

/// The fewest values whose range may stop below the largest.
const MIN_CLIPPED: usize = 20;

impl Bins {
    fn of(values: &[f64]) -> Bins {
        let mut sorted: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        sorted.sort_by(f64::total_cmp);
        let max = sorted.last().copied().unwrap_or(0.0).max(0.0);
        // The 99th percentile, below the largest value however few the rows (one outlier
        // among 20 squashed the other 19 too).
        let below = (sorted.len() / 100).max(1);
        let p99 = (sorted.len().checked_sub(1 + below)).map_or(0.0, |i| sorted[i]);
        // Fewer values are too few to call one an outlier ([0.1, 0.5] would be all in the
        // last bin).
        let clipped = sorted.len() >= MIN_CLIPPED && p99 > 0.0 && max > OUTLIER_SPAN * p99;
        let hi = if clipped { p99 } else { max }.max(1e-12) * 1.0001;
        let width = hi / BINS as f64;
        let mut counts = [0usize; BINS];
        for v in &sorted {
            counts[((v / width).max(0.0) as usize).min(BINS - 1)] += 1;
        }
        let beyond = clipped.then(|| (sorted.iter().filter(|&&v| v >= hi).count(), max));
        Bins { hi, counts, beyond }
    }
}

impl Chart for Histograms {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let (top, body) = root.split_vertically(40);
        top.titled(&self.title, font(22))?;
        let k = self.series.len().max(1);
        let rows = if k > 3 { 2 } else { 1 };
        let panels = body.split_evenly((rows, k.div_ceil(rows)));
        for (k, (s, area)) in self.series.iter().zip(&panels).enumerate() {
            let col = COLOURS[k % COLOURS.len()];
            let Bins { hi, counts, beyond } = Bins::of(&s.values);
            let width = hi / BINS as f64;
            let top_count = counts.iter().copied().max().unwrap_or(1).max(1);
            let mut c = ChartBuilder::on(area)
                .caption(&s.label, font(15))
                .margin(10)
                .x_label_area_size(45)
                .y_label_area_size(55)
                .build_cartesian_2d(0.0..hi, 0.0..top_count as f64 * 1.1)?;
            c.configure_mesh()
                .x_desc(format!(
                    "{}; mean {:.4}{}",
                    self.x_label,
                    mean(&s.values),
                    beyond.map_or(String::new(), |(n, max)| format!(
                        "; last bin also {n} above {}, max {}",
                        short(hi),
                        short(max)
                    ))
                ))
                .y_desc("measurements")
                .axis_desc_style(font(14))
                .label_style(font(12))
                .x_labels(5)
                .x_label_formatter(&|v| short(*v))
                .y_label_formatter(&|v| format!("{v:.0}"))
                .draw()?;
            c.draw_series(counts.iter().enumerate().map(|(i, &n)| {
                let x0 = i as f64 * width;
                Rectangle::new([(x0, 0.0), (x0 + width, n as f64)], col.mix(0.75).filled())
            }))?;
        }
        Ok(())
    }
}

/// Mean squared error by epoch, training and validation, both phases.
pub struct TrainingCurve {
    /// Title drawn above the chart.
    pub title: String,
    /// (epoch, training MSE, tracked value) (normalised outputs): the tracked value is the
    /// held-out part's MSE with `held_out`, else the penalised training objective (MSE plus
    /// the L2 penalty per residual component), what the best weights are chosen by.
    pub curve: Vec<(usize, f64, f64)>,
    /// Whether a part of the training rows was held out (`--validation-fraction`).
    pub held_out: bool,
    /// Epochs of the first (momentum) phase.
    pub momentum_epochs: usize,
    /// The second phase's method (its steps follow the momentum epochs on the x axis).
    pub phase2: Phase2,
}

impl Chart for TrainingCurve {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let vals = self
            .curve
            .iter()
            .flat_map(|c| [c.1, c.2])
            .filter(|v| *v > 0.0 && v.is_finite());
        let lo = vals.clone().fold(f64::INFINITY, f64::min);
        let hi = vals.fold(0.0f64, f64::max);
        let (lo, hi) = if lo.is_finite() && hi > lo {
            (lo * 0.8, hi * 1.25)
        } else {
            (1e-6, 1.0)
        };
        let last = self.curve.last().map_or(1, |c| c.0).max(1);
        // log10 of the MSE on a linear axis: plotters' log axis labels only whole decades,
        // and a curve often spans less than one.
        let (lo, hi) = (lo.log10(), hi.log10());
        let mut c = ChartBuilder::on(root)
            .caption(&self.title, font(22))
            .margin(12)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..last as f64, lo..hi)?;
        c.configure_mesh()
            .x_desc(match self.phase2 {
                Phase2::Lbfgs => "epoch (phase 1: SGD with momentum), then L-BFGS iteration",
                _ => "epoch (phase 1: SGD with momentum, then Levenberg-Marquardt)",
            })
            .y_desc("mean squared error (normalised outputs, log scale)")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|v| format!("{:.2e}", 10f64.powf(*v)))
            .axis_desc_style(font(17))
            .label_style(font(14))
            .draw()?;
        let boundary = self.momentum_epochs as f64;
        c.draw_series(LineSeries::new(
            [(boundary, lo), (boundary, hi)],
            BLACK.mix(0.4).stroke_width(1),
        ))?
        .label("end of phase 1")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.mix(0.4)));
        // Without a held-out part the second line is the training rows' penalised objective,
        // not a validation error (it was labelled so: a gap that did not exist, a helper's).
        let tracked = if self.held_out {
            "validation (held-out part)"
        } else {
            "penalised objective (training MSE + L2 penalty)"
        };
        for (k, name) in ["training", tracked].iter().enumerate() {
            let col = COLOURS[k + 1];
            let pts = self.curve.iter().filter_map(|c| {
                let v = if k == 0 { c.1 } else { c.2 };
                (v > 0.0 && v.is_finite()).then_some((c.0 as f64, v.log10()))
            });
            c.draw_series(LineSeries::new(pts, col.stroke_width(2)))?
                .label(*name)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], col.stroke_width(2)));
        }
        legend(&mut c)
    }
}

/// Tool positions seen from above (x-y) and from the side (x-z), coloured by error.
pub struct Scatter {
    /// Title drawn above the two views.
    pub title: String,
    /// Tool positions (mm).
    pub points: Vec<[f64; 3]>,
    /// One error per point.
    pub errors: Vec<f64>,
    /// Colour-bar title with unit, e.g. "position error (mm)".
    pub label: String,
}

/// Viridis, sampled at 9 points and interpolated; `t` in [0, 1].
pub fn viridis(t: f64) -> RGBColor {
    const V: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let x = t.clamp(0.0, 1.0) * (V.len() - 1) as f64;
    let i = (x.floor() as usize).min(V.len() - 2);
    let f = x - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    RGBColor(
        mix(V[i].0, V[i + 1].0),
        mix(V[i].1, V[i + 1].1),
        mix(V[i].2, V[i + 1].2),
    )
}

fn span(v: impl Iterator<Item = f64> + Clone) -> std::ops::Range<f64> {
    let lo = v.clone().fold(f64::INFINITY, f64::min);
    let hi = v.fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || hi <= lo {
        return -1.0..1.0;
    }
    let pad = 0.05 * (hi - lo);
    lo - pad..hi + pad
}

impl Chart for Scatter {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let (top, body) = root.split_vertically(40);
        top.titled(&self.title, font(22))?;
        let (views, bar) = body.split_horizontally(body.dim_in_pixel().0 - 130);
        let panels = views.split_evenly((1, 2));
        let emax = self
            .errors
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max)
            .max(1e-12);
        // Largest errors drawn last, on top.
        let mut order: Vec<usize> = (0..self.points.len().min(self.errors.len())).collect();
        order.sort_by(|&a, &b| self.errors[a].total_cmp(&self.errors[b]));
        for (area, (axis, name)) in panels.iter().zip([(1, "y (mm)"), (2, "z (mm)")]) {
            let xs = span(self.points.iter().map(|p| p[0]));
            let ys = span(self.points.iter().map(|p| p[axis]));
            let view = if axis == 1 { "top view" } else { "side view" };
            let mut c = ChartBuilder::on(area)
                .caption(view, font(16))
                .margin(10)
                .x_label_area_size(45)
                .y_label_area_size(65)
                .build_cartesian_2d(xs, ys)?;
            c.configure_mesh()
                .x_desc("x (mm)")
                .y_desc(name)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| format!("{v:.0}"))
                .axis_desc_style(font(15))
                .label_style(font(12))
                .x_labels(5)
                .draw()?;
            c.draw_series(order.iter().map(|&i| {
                let p = self.points[i];
                Circle::new((p[0], p[axis]), 4, viridis(self.errors[i] / emax).filled())
            }))?;
        }
        // Colour bar.
        let mut c = ChartBuilder::on(&bar)
            .margin_top(40)
            .margin_bottom(55)
            .margin_right(10)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..1.0, 0.0..emax)?;
        c.configure_mesh()
            .disable_x_mesh()
            .disable_y_mesh()
            .disable_x_axis()
            .y_desc(self.label.as_str())
            .axis_desc_style(font(14))
            .label_style(font(12))
            .y_label_formatter(&|v| short(*v))
            .draw()?;
        let steps = 100;
        c.draw_series((0..steps).map(|k| {
            let (a, b) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
            Rectangle::new([(0.0, a * emax), (1.0, b * emax)], viridis(a).filled())
        }))?;
        Ok(())
    }
}

/// One line of [`Curves`]: a value (and its range) at each x.
#[derive(Debug, Clone)]
pub struct Curve {
    /// Legend name.
    pub label: String,
    /// (x, value, low, high): the line through the values, a whisker from low to high.
    pub points: Vec<(f64, f64, f64, f64)>,
    /// Dashed (for a prediction beside what was realised).
    pub dashed: bool,
}

/// Values against a count, one line with markers and whiskers per curve (planned and
/// random measurements: error against their number).
pub struct Curves {
    /// Title drawn above the chart.
    pub title: String,
    /// Axis title of x, e.g. "configurations measured".
    pub x_label: String,
    /// Axis title of y with unit.
    pub y_label: String,
    /// The curves; colours in order, a dashed curve takes the colour of the one before it.
    pub curves: Vec<Curve>,
}

impl Chart for Curves {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let pts = self.curves.iter().flat_map(|c| c.points.iter());
        let x_hi = pts.clone().map(|p| p.0).fold(1.0f64, f64::max);
        let x_lo = pts.clone().map(|p| p.0).fold(x_hi, f64::min);
        let y_hi = pts.map(|p| p.3.max(p.1)).fold(0.0f64, f64::max).max(1e-12);
        let pad = 0.05 * (x_hi - x_lo).max(1.0);
        let mut c = ChartBuilder::on(root)
            .caption(&self.title, font(22))
            .margin(12)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x_lo - pad..x_hi + pad, 0.0..y_hi * 1.3)?;
        c.configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_label_formatter(&|v| short(*v))
            .axis_desc_style(font(17))
            .label_style(font(14))
            .draw()?;
        let mut colour = 0;
        for (k, curve) in self.curves.iter().enumerate() {
            if k > 0 && !curve.dashed {
                colour += 1;
            }
            let col = COLOURS[colour % COLOURS.len()];
            let line: Vec<(f64, f64)> = curve.points.iter().map(|p| (p.0, p.1)).collect();
            let style = col.stroke_width(2);
            if curve.dashed {
                // Dashed in the legend too.
                c.draw_series(DashedLineSeries::new(line, 8, 6, style))?
                    .label(curve.label.as_str())
                    .legend(move |(x, y)| {
                        EmptyElement::at((x, y))
                            + PathElement::new([(0, 0), (8, 0)], col.stroke_width(2))
                            + PathElement::new([(13, 0), (20, 0)], col.stroke_width(2))
                    });
            } else {
                c.draw_series(LineSeries::new(line.clone(), style))?
                    .label(curve.label.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 20, y)], col.stroke_width(2))
                    });
                c.draw_series(line.iter().map(|&p| Circle::new(p, 4, col.filled())))?;
                // Side by side: the whiskers of curves at the same x do not hide each other.
                let dx = 0.004 * (x_hi - x_lo).max(1.0) * (2.0 * colour as f64 - 1.0);
                c.draw_series(curve.points.iter().map(|p| {
                    PathElement::new([(p.0 + dx, p.2), (p.0 + dx, p.3)], col.stroke_width(2))
                }))?;
            }
        }
        legend(&mut c)
    }
}

#[cfg(test)]
mod tests {
    use super::{BINS, Bins, COLOURS};

    #[test]
    fn one_outlier_does_not_squash_a_histogram() {
        // 299 errors of 0.001..0.299 mm and one of 60 mm: the range ends at the 99th
        // percentile (0.297 mm), the outlier counted in the last bin and told.
        let mut v: Vec<f64> = (1..300).map(|i| i as f64 * 1e-3).collect();
        v.push(60.0);
        let b = Bins::of(&v);
        assert!((b.hi - 0.297 * 1.0001).abs() < 1e-12, "{}", b.hi);
        assert_eq!(b.counts.iter().sum::<usize>(), 300);
        assert!(
            b.counts[..BINS - 1].iter().all(|&n| n <= 15),
            "{:?}",
            b.counts
        );
        assert_eq!(b.counts[BINS - 1], 15 + 3);
        assert_eq!(b.beyond, Some((3, 60.0)));
        // Without an outlier the range ends at the largest value, nothing beyond.
        v.pop();
        let b = Bins::of(&v);
        assert!((b.hi - 0.299 * 1.0001).abs() < 1e-12);
        assert_eq!((b.beyond, b.counts[0], b.counts[BINS - 1]), (None, 14, 15));
        // Not finite: not counted; nothing at all: an empty panel.
        let b = Bins::of(&[f64::NAN, 1.0, f64::INFINITY]);
        assert_eq!((b.counts.iter().sum::<usize>(), b.beyond), (1, None));
        assert_eq!(Bins::of(&[]).counts, [0; BINS]);
        // Few rows: the range ends below the one outlier too.
        let mut v: Vec<f64> = (1..20).map(|i| i as f64 * 0.01).collect();
        v.push(60.0);
        let b = Bins::of(&v);
        assert!((b.hi - 0.19 * 1.0001).abs() < 1e-12, "{}", b.hi);
        assert_eq!(b.beyond, Some((1, 60.0)));
        // Two values are no outlier and its rest.
        assert_eq!(Bins::of(&[0.1, 0.5]).beyond, None);
    }

    #[test]
    fn the_eight_series_of_case_d_have_eight_colours() {
        // `case-d` draws its eight stages in one chart (`studies::case_d::Stage::ALL`).
        assert!(COLOURS.len() >= 8);
        for (i, a) in COLOURS.iter().enumerate() {
            assert!(COLOURS[..i].iter().all(|b| b != a), "colour {i} repeats");
        }
    }
}
