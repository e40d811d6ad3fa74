//! Results that are not studies: plain tables of labelled rows (printed aligned, written as CSV)
//! and a figure of update segments in two projections. Used by the model comparison and the single
//! update of `liebayes aoa`.

use crate::report::{aligned, field};
use plotters::prelude::*;

/// A table of text cells: a file stem, a title, a header and rows of as many cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Sheet {
    /// The stem of its CSV file.
    pub name: String,
    /// The printed heading.
    pub title: String,
    /// The column headings.
    pub header: Vec<String>,
    /// The rows.
    pub rows: Vec<Vec<String>>,
}

impl Sheet {
    /// The table with its columns aligned, under its title.
    pub fn render(&self) -> String {
        let rows: Vec<Vec<String>> = std::iter::once(&self.header)
            .chain(&self.rows)
            .cloned()
            .collect();
        format!("\n{}\n{}", self.title, aligned(&rows))
    }

    /// The table as CSV (cells with a comma, a quote or a line break quoted).
    pub fn csv(&self) -> String {
        let mut text = String::new();
        for row in std::iter::once(&self.header).chain(&self.rows) {
            let cells: Vec<String> = row.iter().map(|c| field(c)).collect();
            text.push_str(&cells.join(","));
            text.push('\n');
        }
        text
    }
}

/// A labelled segment from one point to another (3-D, m).
pub type Segment = (String, [f64; 3], [f64; 3]);

/// An SVG of `segments` (each drawn with a marker at its end) and a ray from `origin` along
/// `direction`, in the x–z and x–y projections side by side.
///
/// # Errors
/// A drawing error, as text.
pub fn segments_svg(
    title: &str,
    segments: &[Segment],
    origin: [f64; 3],
    direction: [f64; 3],
) -> Result<String, String> {
    let ray_end =
        |length: f64| std::array::from_fn::<f64, 3, _>(|i| origin[i] + length * direction[i]);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1100, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let root = root
            .titled(title, ("sans-serif", 18))
            .map_err(|e| e.to_string())?;
        let panels = root.split_evenly((1, 2));
        for (panel, (axis, name)) in panels.iter().zip([(2usize, "z"), (1usize, "y")]) {
            let points: Vec<[f64; 3]> = segments
                .iter()
                .flat_map(|(_, a, b)| [*a, *b])
                .chain([origin, ray_end(1.0)])
                .collect();
            let range = |i: usize| {
                let (lo, hi) = points
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                        (l.min(p[i]), h.max(p[i]))
                    });
                // Halves first: the span of two finite values can overflow.
                let pad = 0.2 * (hi / 2.0 - lo / 2.0).max(0.25);
                crate::report::axis(lo - pad, hi + pad, -1.0..1.0)
            };
            let mut chart = ChartBuilder::on(panel)
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(48)
                .build_cartesian_2d(range(0), range(axis))
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc("x (m)")
                .y_desc(format!("{name} (m)"))
                .draw()
                .map_err(|e| e.to_string())?;
            let end = ray_end(3.0);
            chart
                .draw_series(LineSeries::new(
                    [(origin[0], origin[axis]), (end[0], end[axis])],
                    BLACK.stroke_width(1),
                ))
                .map_err(|e| e.to_string())?
                .label("measured direction")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 16, y)], BLACK));
            for (k, (label, from, to)) in segments.iter().enumerate() {
                let colour = Palette99::pick(k).to_rgba();
                chart
                    .draw_series(LineSeries::new(
                        [(from[0], from[axis]), (to[0], to[axis])],
                        colour.stroke_width(2),
                    ))
                    .map_err(|e| e.to_string())?
                    .label(label.clone())
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], colour));
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (to[0], to[axis]),
                        4,
                        colour.filled(),
                    )))
                    .map_err(|e| e.to_string())?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}
