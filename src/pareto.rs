//! Pareto marking of (time, error) points and SVG pictures of the frontier.
//!
//! Both coordinates are minimised: x is a cost (e.g. GPU time in ms), y an error.

use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Marks which points are on the Pareto front, both coordinates minimised.
///
/// Point `p` is on the front iff no other point `q` has `q.x <= p.x` and `q.y <= p.y` with at
/// least one of them strict. Consequences:
/// - exact duplicates do not dominate each other, so both copies of a front point stay on the
///   front;
/// - a point equal in x but worse in y (or equal in y, worse in x) is dominated;
/// - a point with a NaN coordinate is never on the front and never dominates another;
/// - infinities compare as ordinary values.
///
/// Returns one flag per input point, in input order. O(n²), meant for n up to a few thousand.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let dominates = |q: (f64, f64), p: (f64, f64)| q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1);
    points.iter().map(|&p| !p.0.is_nan() && !p.1.is_nan() && !points.iter().any(|&q| dominates(q, p))).collect()
}

/// One point of a frontier picture.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotPoint {
    /// Cost coordinate (e.g. time in ms).
    pub x: f64,
    /// Error coordinate.
    pub y: f64,
    /// Text drawn next to the point when it is on the front.
    pub label: String,
    /// The series the point belongs to (a GI technique): each has its own colour.
    pub group: String,
    /// Whether the point is on the Pareto front (e.g. from [`pareto_front`]).
    pub front: bool,
}

/// Errors of [`frontier_svg`], naming the output file.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Plotters failed to lay out or draw the chart.
    #[error("cannot draw {}: {message}", path.display())]
    Draw {
        /// The output file.
        path: PathBuf,
        /// Plotters' error, as text.
        message: String,
    },
    /// The file could not be written (the output layer's atomic write; the message names it).
    #[error(transparent)]
    Write(#[from] crate::output::OutputError),
}

/// Size of the picture in SVG user units (pixels).
const SIZE: (u32, u32) = (960, 640);
const FRONT_COLOR: RGBColor = RGBColor(40, 40, 40);
/// One colour per group, in order of first appearance (then repeating).
const GROUP_COLORS: [RGBColor; 5] = [
    RGBColor(214, 69, 35),
    RGBColor(33, 113, 181),
    RGBColor(35, 139, 69),
    RGBColor(117, 107, 177),
    RGBColor(150, 150, 150),
];

/// Draws a scatter plot of `points` as an SVG file at `path`.
///
/// Dominated points are small grey dots; front points are larger coloured dots joined by a
/// step line in x order (the staircase of what is attainable) and labelled with their
/// `label`. Axis ranges are the data ranges padded by 5 % (multiplicatively with `log_y`).
/// With `log_y` the y axis is logarithmic, and y values ≤ 0 are drawn at half the smallest
/// positive y (at 1 if there is none). Points with a non-finite coordinate are left out.
///
/// The picture is rendered in memory and written with [`crate::output::write_bytes`]
/// (a temporary sibling renamed onto `path`), so a failure never leaves a half-written `path`. SVG text needs no
/// font files: plotters' SVG backend emits `<text>` elements with a font-family name.
pub fn frontier_svg(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    points: &[PlotPoint],
    log_x: bool,
    log_y: bool,
) -> Result<(), PlotError> {
    let finite: Vec<&PlotPoint> = points.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).collect();
    let min_positive = finite.iter().map(|p| p.y).filter(|&y| y > 0.0).fold(f64::INFINITY, f64::min);
    let floor = if min_positive.is_finite() { min_positive / 2.0 } else { 1.0 };
    let min_positive_x = finite.iter().map(|p| p.x).filter(|&x| x > 0.0).fold(f64::INFINITY, f64::min);
    let floor_x = if min_positive_x.is_finite() { min_positive_x / 2.0 } else { 1.0 };
    let ys = |p: &PlotPoint| if log_y { p.y.max(floor) } else { p.y };
    let xs = |p: &PlotPoint| if log_x { p.x.max(floor_x) } else { p.x };
    let placed: Vec<(f64, f64, &PlotPoint)> = finite.iter().map(|p| (xs(p), ys(p), *p)).collect();
    // A log axis over less than a decade gets no ticks from plotters: keep such axes linear.
    let spans_decade = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
        hi > 10.0 * lo
    };
    let log_x = log_x && spans_decade(&mut placed.iter().map(|p| p.0));
    let log_y = log_y && spans_decade(&mut placed.iter().map(|p| p.1));

    let spec = Spec { title, x_label, y_label, points: &placed, log_x };
    let mut svg = String::new();
    let drawn = {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        let xl = || linear_range(placed.iter().map(|p| p.0));
        let xg = || log_range(placed.iter().map(|p| p.0));
        let yl = || linear_range(placed.iter().map(|p| p.1));
        let yg = || log_range(placed.iter().map(|p| p.1));
        let result = match (log_x, log_y) {
            (false, false) => draw_chart(&root, &spec, xl(), yl()),
            (false, true) => draw_chart(&root, &spec, xl(), yg().log_scale()),
            (true, false) => draw_chart(&root, &spec, xg().log_scale(), yl()),
            (true, true) => draw_chart(&root, &spec, xg().log_scale(), yg().log_scale()),
        };
        result.and_then(|()| root.present())
    };
    drawn.map_err(|e| PlotError::Draw { path: path.to_path_buf(), message: e.to_string() })?;
    Ok(crate::output::write_bytes(path, svg.as_bytes())?)
}

struct Spec<'a> {
    title: &'a str,
    x_label: &'a str,
    y_label: &'a str,
    points: &'a [(f64, f64, &'a PlotPoint)],
    log_x: bool,
}

fn draw_chart<X, Y>(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    spec: &Spec<'_>,
    x_range: X,
    y_range: Y,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>>
where
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y: AsRangedCoord<Value = f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(spec.title, ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(x_range, y_range)?;
    chart
        .configure_mesh()
        .x_desc(spec.x_label)
        .y_desc(spec.y_label)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .max_light_lines(4)
        .light_line_style(RGBColor(238, 238, 238))
        .draw()?;

    // Every point in its group's colour: dominated ones small and pale, the front's large.
    let mut groups: Vec<&str> = Vec::new();
    for p in spec.points {
        if !groups.contains(&p.2.group.as_str()) {
            groups.push(&p.2.group);
        }
    }
    let color = |g: &str| GROUP_COLORS[groups.iter().position(|x| *x == g).unwrap_or(0) % GROUP_COLORS.len()];
    for g in &groups {
        let c = color(g);
        let mine = || spec.points.iter().filter(move |p| p.2.group == *g);
        chart
            .draw_series(mine().filter(|p| !p.2.front).map(|p| Circle::new((p.0, p.1), 3, c.mix(0.45).filled())))?
            .label(if g.is_empty() { "dominated".to_owned() } else { g.to_string() })
            .legend(move |(x, y)| Circle::new((x, y), 4, c.filled()));
    }
    let mut front: Vec<(f64, f64, &PlotPoint)> = spec.points.iter().filter(|p| p.2.front).copied().collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut steps = Vec::with_capacity(front.len() * 2);
    for (i, p) in front.iter().enumerate() {
        if i > 0 {
            steps.push((p.0, front[i - 1].1));
        }
        steps.push((p.0, p.1));
    }
    chart.draw_series(LineSeries::new(steps, FRONT_COLOR.stroke_width(2)))?;
    // Labels sit above their point, right of it in the left half of the plot and left of it
    // in the right half, so they stay inside the picture.
    let xs: Vec<f64> = spec.points.iter().map(|p| p.0).collect();
    let (lo, hi) =
        (xs.iter().copied().fold(f64::INFINITY, f64::min), xs.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    let middle = if spec.log_x { (lo * hi).sqrt() } else { (lo + hi) / 2.0 };
    chart
        .draw_series(front.iter().map(|p| {
            let (dx, h) = if p.0 <= middle { (7, HPos::Left) } else { (-7, HPos::Right) };
            let style = ("sans-serif", 12).into_font().color(&BLACK).pos(Pos::new(h, VPos::Bottom));
            EmptyElement::at((p.0, p.1))
                + Circle::new((0, 0), 5, color(&p.2.group).filled())
                + Text::new(p.2.label.clone(), (dx, -4), style)
        }))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x - 6, y), (x + 6, y)], FRONT_COLOR.stroke_width(2)));

    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// Data range padded by 5 % of its span (or ±max(5 % of |value|, 1) when the span is 0).
fn linear_range(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let pad = if hi > lo { (hi - lo) * 0.05 } else { (lo.abs() * 0.05).max(1.0) };
    lo - pad..hi + pad
}

/// Positive data range padded by 5 % of its span in log space (at least a factor 1.2).
fn log_range(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !lo.is_finite() {
        return 0.1..10.0;
    }
    let factor = (hi / lo).powf(0.05).max(1.2);
    lo / factor..hi * factor
}

/// Compact tick text: up to 4 significant digits, scientific outside [1e-3, 1e5).
fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".to_owned();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        return format!("{v:.2e}");
    }
    let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn front_of_a_hand_made_set() {
        let pts = [
            (1.0, 10.0),     // 0 front: fastest
            (2.0, 5.0),      // 1 front
            (2.0, 6.0),      // 2 same x as 1, worse y: dominated
            (3.0, 5.0),      // 3 same y as 1, slower: dominated
            (4.0, 2.0),      // 4 front
            (4.0, 2.0),      // 5 exact duplicate of 4: both stay on the front
            (f64::NAN, 0.0), // 6 NaN: never on the front, and dominates nothing
            (5.0, 3.0),      // 7 dominated by 4
            (8.0, 1.0),      // 8 front: most accurate
            (0.5, f64::NAN), // 9 NaN
            (9.0, 1.0),      // 10 dominated by 8
        ];
        let expect = [true, true, false, false, true, true, false, false, true, false, false];
        assert_eq!(pareto_front(&pts), expect);
    }

    #[test]
    fn front_edge_cases() {
        assert_eq!(pareto_front(&[]), Vec::<bool>::new());
        assert_eq!(pareto_front(&[(3.0, 4.0)]), [true]);
        assert_eq!(pareto_front(&[(f64::NAN, f64::NAN)]), [false]);
        assert_eq!(pareto_front(&[(1.0, 1.0), (1.0, 1.0), (1.0, 1.0)]), [true, true, true]);
        // A trade-off: neither dominates.
        assert_eq!(pareto_front(&[(1.0, 2.0), (2.0, 1.0)]), [true, true]);
        // Infinity compares normally.
        assert_eq!(pareto_front(&[(f64::INFINITY, 0.0), (1.0, 1.0), (2.0, f64::INFINITY)]), [true, true, false]);
    }

    fn sample_points() -> Vec<PlotPoint> {
        let raw = [
            (1.2, 0.30, "mips=4"),
            (2.0, 0.12, "cones=6 & <fast>"),
            (2.5, 0.20, "cones=5"),
            (4.1, 0.05, "cones=9"),
            (4.5, 0.09, "cones=8"),
            (9.0, 0.0, "reference"),
        ];
        let front = pareto_front(&raw.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>());
        raw.iter()
            .zip(front)
            .map(|(p, front)| PlotPoint { x: p.0, y: p.1, label: p.2.to_owned(), group: String::new(), front })
            .collect()
    }

    fn check_svg(text: &str, points: &[PlotPoint], title: &str) {
        assert!(text.starts_with("<svg"), "{}", &text[..text.len().min(200)]);
        assert!(text.trim_end().ends_with("</svg>"));
        assert_eq!(text.matches("<svg").count(), 1);
        assert_eq!(text.matches("</svg>").count(), 1);
        assert!(text.contains(title));
        for p in points.iter().filter(|p| p.front) {
            let escaped = p.label.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
            assert!(text.contains(&escaped), "missing label {:?}", p.label);
        }
        // Raw markup characters from labels never leak unescaped.
        assert!(!text.contains("<fast>"));
        // Every opened text element is closed.
        assert_eq!(text.matches("<text").count(), text.matches("</text>").count());
    }

    #[test]
    fn svg_linear_and_log() {
        let dir = tempfile::tempdir().unwrap();
        let points = sample_points();
        assert_eq!(points.iter().filter(|p| p.front).count(), 4, "{points:?}");
        for log_y in [false, true] {
            let path = dir.path().join(format!("front-{log_y}.svg"));
            frontier_svg(&path, "Cornell box: time vs FLIP", "GPU time (ms)", "mean FLIP", &points, false, log_y)
                .unwrap();
            let text = std::fs::read_to_string(&path).unwrap();
            check_svg(&text, &points, "Cornell box: time vs FLIP");
            assert!(text.contains("GPU time (ms)") && text.contains("mean FLIP"));
        }
        // Only the two pictures: no temporary file left behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    #[test]
    fn svg_degenerate_inputs() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.svg");
        frontier_svg(&path, "nothing", "x", "y", &[], true, true).unwrap();
        check_svg(&std::fs::read_to_string(&path).unwrap(), &[], "nothing");
        let one = [PlotPoint { x: 3.0, y: 0.0, label: "only".into(), group: String::new(), front: true }];
        let nan = PlotPoint { x: f64::NAN, y: 1.0, label: "nan".into(), group: String::new(), front: false };
        for log_y in [false, true] {
            frontier_svg(&path, "one", "x", "y", &[one[0].clone(), nan.clone()], log_y, log_y).unwrap();
            check_svg(&std::fs::read_to_string(&path).unwrap(), &one, "one");
        }
    }

    #[test]
    fn svg_error_names_path_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no-such-dir").join("plot.svg");
        let e = frontier_svg(&path, "t", "x", "y", &sample_points(), false, false).unwrap_err();
        assert!(e.to_string().contains("no-such-dir"), "{e}");
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "nothing written");
    }

    #[test]
    fn tick_text() {
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(12.0), "12");
        assert_eq!(tick(0.30000000000000004), "0.3");
        assert_eq!(tick(1234.5678), "1235");
        assert_eq!(tick(0.00012), "1.20e-4");
    }
}
