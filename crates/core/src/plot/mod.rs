//! SVG plots drawn with plotters, embedded in the HTML (no files, no network).

pub mod lines;

use crate::dof::Dof;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use std::ops::Range;
use std::sync::Once;

/// DejaVu Sans (fonts-dejavu-core, Bitstream Vera licence; see crates/core/assets/fonts): plotters'
/// `ab_glyph` text needs a registered font, and the report must not depend on system fonts.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn ensure_font() {
    REGISTER.call_once(|| {
        // The bytes are a valid TTF shipped with the crate; failure is a broken build.
        register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| ())
            .expect("embedded font parses");
    });
}

/// One measured trace and the model's prediction for it.
pub struct Trace<'a> {
    pub label: &'a str,
    pub t: &'a [f64],
    pub measured: &'a [f64],
    pub simulated: &'a [f64],
}

/// Orders traces as their measured curves end, highest first, so the legend reads top to
/// bottom as the curves do (for a family of force levels, their physical order: 100 N after
/// 90 N, never between 10 N and 15 N as the names sort).
pub fn sort_by_final_value(traces: &mut [Trace]) {
    let last = |tr: &Trace| {
        tr.measured
            .iter()
            .rev()
            .find(|v| v.is_finite())
            .copied()
            .unwrap_or(f64::NEG_INFINITY)
    };
    traces.sort_by(|a, b| {
        last(b)
            .total_cmp(&last(a))
            .then_with(|| a.label.cmp(b.label))
    });
}

/// Twenty distinguishable colours (Tableau 20 order), so a plot of many cases never repeats one.
const PALETTE: [RGBColor; 20] = [
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
    RGBColor(174, 199, 232),
    RGBColor(255, 187, 120),
    RGBColor(152, 223, 138),
    RGBColor(255, 152, 150),
    RGBColor(197, 176, 213),
    RGBColor(196, 156, 148),
    RGBColor(247, 182, 210),
    RGBColor(199, 199, 199),
    RGBColor(219, 219, 141),
    RGBColor(158, 218, 229),
];

/// At most ~400 points per trace keep the page small without visible loss.
fn thin<'a>(t: &'a [f64], y: &'a [f64]) -> impl Iterator<Item = (f64, f64)> + Clone + 'a {
    let stride = t.len().div_ceil(400).max(1);
    t.iter().zip(y).step_by(stride).map(|(a, b)| (*a, *b))
}

const WIDTH: u32 = 960;
const HEIGHT: u32 = 400;
const LEGEND: u32 = 200;

/// Velocity responses of one DOF: each CFD case in colour, the fitted model dashed black on
/// top, and a legend naming every case in a column of its own.
pub fn velocity(dof: Dof, traces: &[Trace]) -> anyhow::Result<String> {
    curves(
        &format!("{dof}: CFD response and identified model"),
        "time (s)",
        &format!("{} ({})", dof.velocity(), dof.velocity_unit()),
        traces,
        "identified model (dashed)",
    )
}

/// Measured curves in colour against x, each with its model curve dashed black on top.
pub fn curves(
    title: &str,
    x_desc: &str,
    y_desc: &str,
    traces: &[Trace],
    dashed: &str,
) -> anyhow::Result<String> {
    ensure_font();
    let (x_range, y_range) = curves_ranges(traces);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE)?;
        let (plot, legend) = root.split_horizontally(WIDTH - LEGEND);
        let mut chart = ChartBuilder::on(&plot)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(x_range, y_range)?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .label_style(("sans-serif", 13))
            .draw()?;
        let ok = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
        for (i, tr) in traces.iter().enumerate() {
            chart.draw_series(LineSeries::new(
                thin(tr.t, tr.measured).filter(ok),
                PALETTE[i % PALETTE.len()].stroke_width(3),
            ))?;
        }
        for tr in traces {
            chart.draw_series(DashedLineSeries::new(
                thin(tr.t, tr.simulated).filter(ok),
                6,
                4,
                BLACK.stroke_width(1),
            ))?;
        }
        draw_legend(&legend, traces, dashed)?;
        root.present()?;
    }
    Ok(svg)
}

/// The axes of `curves`: x over the traces' finite abscissae (starting at 0 or below), y over
/// every finite measured and simulated value and 0, padded by 5 % of its span.
fn curves_ranges(traces: &[Trace]) -> (Range<f64>, Range<f64>) {
    let finite = |v: &&f64| v.is_finite();
    let xmax = traces
        .iter()
        .flat_map(|tr| tr.t.iter().filter(finite))
        .fold(f64::MIN, |a, b| a.max(*b));
    let xmin = traces
        .iter()
        .flat_map(|tr| tr.t.iter().filter(finite))
        .fold(f64::MAX, |a, b| a.min(*b))
        .min(0.0);
    let xmax = if xmax > xmin { xmax } else { xmin + 1e-3 };
    let (lo, hi) = traces
        .iter()
        .flat_map(|tr| tr.measured.iter().chain(tr.simulated).filter(finite))
        .fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let pad = 0.05 * (hi - lo).max(1e-6);
    (xmin..xmax, (lo - pad)..(hi + pad))
}

/// The legend column: each trace's colour and label, then the dashed line and what it is.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    traces: &[Trace],
    dashed: &str,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let font = ("sans-serif", 12).into_font();
    let row = 17;
    let mut y = 40;
    for (i, tr) in traces.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        area.draw(&PathElement::new(
            vec![(8, y), (30, y)],
            color.stroke_width(3),
        ))?;
        area.draw(&Text::new(tr.label.to_string(), (36, y - 7), font.clone()))?;
        y += row;
    }
    area.draw(&PathElement::new(
        vec![(8, y), (30, y)],
        BLACK.stroke_width(1),
    ))?;
    area.draw(&Text::new(dashed.to_string(), (36, y - 7), font))?;
    Ok(())
}

/// One DOF of a pool run: the fused measurement with its ±2σ band, the model's simulation.
pub struct PoolTrace<'a> {
    pub dof: Dof,
    pub t: &'a [f64],
    pub measured: &'a [f64],
    pub std: &'a [f64],
    pub simulated: &'a [f64],
}

/// The height of one DOF's panel in a pool-run plot (velocity above, error beneath).
const POOL_PANEL: u32 = 300;

/// A pool run, one panel per DOF: measured velocity (blue, ±2σ band) against the model
/// (dashed black), and beneath it the error model − measured with the band around zero.
pub fn pool_run(run: &str, model: &str, traces: &[PoolTrace]) -> anyhow::Result<String> {
    ensure_font();
    let height = POOL_PANEL * traces.len().max(1) as u32 + 30;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let (title, body) = root.split_vertically(30);
        title.draw(&Text::new(
            format!("pool run {run}: fused velocity (blue, ±2σ band) and model {model} (dashed)"),
            (12, 8),
            ("sans-serif", 16).into_font(),
        ))?;
        let panels = body.split_evenly((traces.len().max(1), 1));
        for (tr, area) in traces.iter().zip(panels) {
            let (top, bottom) = area.split_vertically(POOL_PANEL * 62 / 100);
            let tmax = tr.t.last().copied().unwrap_or(1.0).max(1e-3);
            velocity_panel(&top, tr, tmax)?;
            error_panel(&bottom, tr, tmax)?;
        }
        root.present()?;
    }
    Ok(svg)
}

/// A drawing area of an SVG plot.
type SvgArea<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// The upper part of a pool-run panel: the fused velocity (blue) in its ±2σ band and the
/// model's simulation (dashed black), over 0..`tmax` s.
fn velocity_panel(area: &SvgArea, tr: &PoolTrace, tmax: f64) -> anyhow::Result<()> {
    let blue = PALETTE[0];
    let finite = |v: &&f64| v.is_finite();
    let (lo, hi) = tr
        .measured
        .iter()
        .chain(tr.simulated)
        .filter(finite)
        .fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let pad = 0.08 * (hi - lo).max(1e-6);
    let unit = tr.dof.velocity_unit();
    let mut chart = ChartBuilder::on(area)
        .margin_left(12)
        .margin_right(20)
        .margin_top(6)
        .x_label_area_size(0)
        .y_label_area_size(64)
        .build_cartesian_2d(0f64..tmax, (lo - pad)..(hi + pad))?;
    chart
        .configure_mesh()
        .y_desc(format!("{} ({unit})", tr.dof.velocity()))
        .y_labels(6)
        .light_line_style(TRANSPARENT)
        .label_style(("sans-serif", 12))
        .draw()?;
    chart.draw_series(std::iter::once(Polygon::new(
        measured_band(tr.t, tr.measured, tr.std),
        blue.mix(0.25).filled(),
    )))?;
    chart.draw_series(LineSeries::new(
        thin(tr.t, tr.measured),
        blue.stroke_width(2),
    ))?;
    chart.draw_series(DashedLineSeries::new(
        thin(tr.t, tr.simulated).filter(|p| p.1.is_finite()),
        6,
        4,
        BLACK.stroke_width(1),
    ))?;
    Ok(())
}

/// The outline of the ±2σ band around the measured velocity: its upper edge forwards in time,
/// then its lower edge backwards.
fn measured_band(t: &[f64], measured: &[f64], std: &[f64]) -> Vec<(f64, f64)> {
    let edge = |sign: f64| {
        thin(t, measured)
            .zip(thin(t, std))
            .map(move |((t, m), (_, s))| (t, m + sign * 2.0 * s))
    };
    edge(1.0)
        .chain(edge(-1.0).collect::<Vec<_>>().into_iter().rev())
        .collect()
}

/// The lower part of a pool-run panel: the error model − measured (red) inside the ±2σ band
/// around zero, over 0..`tmax` s.
fn error_panel(area: &SvgArea, tr: &PoolTrace, tmax: f64) -> anyhow::Result<()> {
    let finite = |v: &&f64| v.is_finite();
    let err: Vec<f64> = tr
        .simulated
        .iter()
        .zip(tr.measured)
        .map(|(s, m)| s - m)
        .collect();
    let emax = err
        .iter()
        .chain(tr.std.iter().map(|s| s * 2.0).collect::<Vec<_>>().iter())
        .filter(finite)
        .fold(0.0f64, |a, b| a.max(b.abs()))
        .max(1e-6)
        * 1.1;
    let mut echart = ChartBuilder::on(area)
        .margin_left(12)
        .margin_right(20)
        .margin_bottom(4)
        .x_label_area_size(34)
        .y_label_area_size(64)
        .build_cartesian_2d(0f64..tmax, -emax..emax)?;
    echart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc("error")
        .y_labels(3)
        .light_line_style(TRANSPARENT)
        .label_style(("sans-serif", 12))
        .draw()?;
    echart.draw_series(std::iter::once(Polygon::new(
        zero_band(tr),
        PALETTE[0].mix(0.2).filled(),
    )))?;
    echart.draw_series(LineSeries::new(
        thin(tr.t, &err).filter(|p| p.1.is_finite()),
        PALETTE[3].stroke_width(1),
    ))?;
    Ok(())
}

/// The outline of the ±2σ band around zero: its upper edge forwards in time, then its lower
/// edge backwards.
fn zero_band(tr: &PoolTrace) -> Vec<(f64, f64)> {
    thin(tr.t, tr.std)
        .map(|(t, s)| (t, 2.0 * s))
        .chain(
            thin(tr.t, tr.std)
                .map(|(t, s)| (t, -2.0 * s))
                .collect::<Vec<_>>()
                .into_iter()
                .rev(),
        )
        .collect()
}

/// A recording against two simulations of it on the same axes: the fused measurement (blue, in
/// its ±2σ band), the model as given (dashed black), and the model with what the diagnosis
/// added (red).
pub struct Overlay<'a> {
    pub title: &'a str,
    pub y_desc: &'a str,
    pub t: &'a [f64],
    pub recorded: &'a [f64],
    pub std: &'a [f64],
    pub model: (&'a str, &'a [f64]),
    pub augmented: (&'a str, &'a [f64]),
}

pub fn overlay(o: &Overlay) -> anyhow::Result<String> {
    ensure_font();
    let finite = |v: &&f64| v.is_finite();
    let (lo, hi) = o
        .recorded
        .iter()
        .chain(o.model.1)
        .chain(o.augmented.1)
        .filter(finite)
        .fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let pad = 0.05 * (hi - lo).max(1e-6);
    let tmax = o.t.last().copied().unwrap_or(1.0).max(1e-3);
    let ok = |p: &(f64, f64)| p.1.is_finite();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE)?;
        let (plot, legend) = root.split_horizontally(WIDTH - LEGEND);
        let mut chart = ChartBuilder::on(&plot)
            .caption(o.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(0f64..tmax, (lo - pad)..(hi + pad))?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_desc(o.y_desc)
            .label_style(("sans-serif", 13))
            .draw()?;
        let blue = PALETTE[0];
        chart.draw_series(std::iter::once(Polygon::new(
            measured_band(o.t, o.recorded, o.std),
            blue.mix(0.25).filled(),
        )))?;
        chart.draw_series(LineSeries::new(
            thin(o.t, o.recorded).filter(ok),
            blue.stroke_width(3),
        ))?;
        chart.draw_series(DashedLineSeries::new(
            thin(o.t, o.model.1).filter(ok),
            6,
            4,
            BLACK.stroke_width(1),
        ))?;
        chart.draw_series(LineSeries::new(
            thin(o.t, o.augmented.1).filter(ok),
            PALETTE[3].stroke_width(1),
        ))?;
        let font = ("sans-serif", 12).into_font();
        let rows: [(&str, ShapeStyle); 4] = [
            ("recording (fused)", blue.stroke_width(3)),
            ("±2σ of the recording", blue.mix(0.25).stroke_width(8)),
            (o.model.0, BLACK.stroke_width(1)),
            (o.augmented.0, PALETTE[3].stroke_width(1)),
        ];
        for (k, (label, style)) in rows.iter().enumerate() {
            let y = 40 + 17 * k as i32;
            legend.draw(&PathElement::new(vec![(8, y), (30, y)], *style))?;
            legend.draw(&Text::new(label.to_string(), (36, y - 7), font.clone()))?;
        }
        root.present()?;
    }
    Ok(svg)
}
