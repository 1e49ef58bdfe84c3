//! A general line chart: named series against a shared x axis, the first drawn thick (the
//! measurement), the others thin, optional horizontal reference lines (a confidence band).
//! Used by the field-trial sections (ARX simulations, RLS traces, autocorrelations).

use super::{HEIGHT, LEGEND, PALETTE, WIDTH, ensure_font, thin};
use maud::{Markup, PreEscaped, html};
use plotters::prelude::*;

/// One curve.
pub struct Series<'a> {
    pub label: &'a str,
    pub x: &'a [f64],
    pub y: &'a [f64],
    /// Dashed black (a truth or reference) instead of a palette colour.
    pub reference: bool,
}

pub struct Chart<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub series: Vec<Series<'a>>,
    /// Horizontal lines drawn dotted grey at these values (a band: `[-b, b]`).
    pub hlines: Vec<f64>,
    /// Draw the points of each series as stems from zero (an autocorrelation).
    pub stems: bool,
}

impl<'a> Chart<'a> {
    /// Lines only: no reference lines, no stems.
    pub fn lines(
        title: &'a str,
        x_desc: &'a str,
        y_desc: &'a str,
        series: Vec<Series<'a>>,
    ) -> Self {
        Chart {
            title,
            x_desc,
            y_desc,
            series,
            hlines: vec![],
            stems: false,
        }
    }
}

pub fn chart(c: &Chart) -> anyhow::Result<String> {
    ensure_font();
    let finite = |v: &&f64| v.is_finite();
    let xs = c.series.iter().flat_map(|s| s.x.iter().filter(finite));
    let (x0, x1) = xs.fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    let ys = c
        .series
        .iter()
        .flat_map(|s| s.y.iter().filter(finite))
        .chain(c.hlines.iter());
    let (y0, y1) = ys.fold((0.0f64, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
    let (x0, x1) = if x1 > x0 { (x0, x1) } else { (0.0, 1.0) };
    let pad = 0.05 * (y1 - y0).max(1e-9);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE)?;
        let (plot, legend) = root.split_horizontally(WIDTH - LEGEND);
        let mut chart = ChartBuilder::on(&plot)
            .caption(c.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(72)
            .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))?;
        chart
            .configure_mesh()
            .x_desc(c.x_desc)
            .y_desc(c.y_desc)
            .label_style(("sans-serif", 13))
            .draw()?;
        for h in &c.hlines {
            chart.draw_series(DashedLineSeries::new(
                [(x0, *h), (x1, *h)],
                2,
                4,
                RGBColor(120, 120, 120).stroke_width(1),
            ))?;
        }
        let ok = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
        for (i, s) in c.series.iter().enumerate() {
            let style = style(i, s);
            if c.stems {
                // A thin line through the points, then the stems.
                chart.draw_series(LineSeries::new(
                    s.x.iter().zip(s.y).map(|(a, b)| (*a, *b)).filter(ok),
                    style.stroke_width(1),
                ))?;
                for (x, y) in s.x.iter().zip(s.y).filter(|(_, y)| y.is_finite()) {
                    chart.draw_series(LineSeries::new([(*x, 0.0), (*x, *y)], style))?;
                    chart.draw_series(std::iter::once(Circle::new((*x, *y), 3, style.filled())))?;
                }
            } else if s.reference {
                chart.draw_series(DashedLineSeries::new(
                    thin(s.x, s.y).filter(ok),
                    6,
                    4,
                    style,
                ))?;
            } else {
                chart.draw_series(LineSeries::new(thin(s.x, s.y).filter(ok), style))?;
            }
        }
        let font = ("sans-serif", 12).into_font();
        for (row, (i, s)) in c
            .series
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.label.is_empty())
            .enumerate()
        {
            let y = 40 + 17 * row as i32;
            legend.draw(&PathElement::new(vec![(8, y), (30, y)], style(i, s)))?;
            legend.draw(&Text::new(s.label.to_string(), (36, y - 7), font.clone()))?;
        }
        root.present()?;
    }
    Ok(svg)
}

fn style(i: usize, s: &Series) -> ShapeStyle {
    if s.reference {
        BLACK.stroke_width(1)
    } else if i == 0 {
        PALETTE[0].stroke_width(3)
    } else {
        PALETTE[i % PALETTE.len()].stroke_width(1)
    }
}

/// `c` as an HTML figure with id `id` and caption `caption` (HTML, already escaped).
pub fn figure(id: &str, caption: Markup, c: &Chart) -> anyhow::Result<Markup> {
    let svg = chart(c)?;
    Ok(html! { figure id=(id) { (PreEscaped(svg)) figcaption { (caption) } } })
}

/// An autocorrelation by lag with the band of a white sequence (a residual test), drawn as
/// stems with the band dotted.
pub struct Correlogram<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub label: &'a str,
    pub lags: &'a [f64],
    pub acf: &'a [f64],
    pub band: f64,
}

impl Correlogram<'_> {
    /// Lags past zero whose autocorrelation is outside the band.
    pub fn outside(&self) -> usize {
        self.acf
            .iter()
            .skip(1)
            .filter(|a| a.abs() > self.band)
            .count()
    }

    /// As an HTML figure (see [`figure`]).
    pub fn figure(&self, id: &str, caption: Markup) -> anyhow::Result<Markup> {
        figure(
            id,
            caption,
            &Chart {
                title: self.title,
                x_desc: self.x_desc,
                y_desc: "autocorrelation",
                series: vec![Series {
                    label: self.label,
                    x: self.lags,
                    y: self.acf,
                    reference: false,
                }],
                hlines: vec![-self.band, self.band],
                stems: true,
            },
        )
    }
}
