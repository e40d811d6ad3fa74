//! The azimuth study's files: CSV tables and SVG plots of the estimate errors with their ±1σ bounds.

use liebayes::filters::azimuth::Summary;
use liebayes::filters::azimuth::study::{Epoch, Run};
use plotters::prelude::*;
use std::error::Error;
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

type Result<T> = std::result::Result<T, Box<dyn Error>>;
/// A value and its σ read off an epoch.
type EpochPick = fn(&Epoch) -> (Option<f64>, Option<f64>);
/// Per-epoch RMSE and RMS σ read off a summary.
type SummaryPick = fn(&Summary) -> (Vec<Option<f64>>, Vec<Option<f64>>);
/// A method's label, its RMSE curve and its σ curve.
type Curve = (String, Vec<(f64, f64)>, Vec<(f64, f64)>);

const COLOURS: [RGBColor; 6] = [
    RGBColor(0, 0, 0),
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
];

/// Writes the files of one scenario into `dir` and returns their paths: the table of `summaries`, and the
/// errors over time of `plotted` (the same methods, all over the same runs).
pub fn write_scenario(
    dir: &Path,
    summaries: &[Summary],
    plotted: &[Summary],
) -> Result<Vec<PathBuf>> {
    let Some(first) = summaries.first() else {
        return Ok(Vec::new());
    };
    fs::create_dir_all(dir)?;
    let name = first.scenario.name();
    let mut written = Vec::new();
    let mut write = |file: String, text: String| -> Result<()> {
        let path = dir.join(file);
        fs::write(&path, text)?;
        written.push(path);
        Ok(())
    };
    write(
        format!("azimuth_{name}_summary.csv"),
        summary_csv(summaries)?,
    )?;
    write(
        format!("azimuth_{name}_first_run.csv"),
        first_run_csv(summaries)?,
    )?;
    write(
        format!("azimuth_{name}_over_time.csv"),
        over_time_csv(summaries)?,
    )?;
    let run_plot = dir.join(format!("azimuth_{name}_first_run.svg"));
    plot_first_run(&run_plot, first)?;
    written.push(run_plot);
    let time_plot = dir.join(format!("azimuth_{name}_rmse.svg"));
    plot_over_time(&time_plot, plotted)?;
    written.push(time_plot);
    Ok(written)
}

fn optional(x: Option<f64>) -> String {
    x.map_or(String::new(), |v| format!("{v:.6e}"))
}

fn summary_csv(summaries: &[Summary]) -> Result<String> {
    let mut out = String::from(
        "method,runs,failures,azimuth_rmse_deg,mean_sigma_a_deg,average_nees_r,nees_band_low,\
         nees_band_high,circular_consistency,circular_band_low,circular_band_high,divergence_rate,\
         ns_per_step\n",
    );
    for s in summaries {
        let band = s.circular.band();
        writeln!(
            out,
            "{},{},{},{},{},{:.6e},{:.6e},{:.6e},{},{},{},{},{:.1}",
            s.method.label(),
            s.runs,
            s.failures,
            optional(s.azimuth_rmse.map(f64::to_degrees)),
            optional(s.mean_sigma_a.map(f64::to_degrees)),
            s.average_nees,
            s.nees_band.0,
            s.nees_band.1,
            optional(s.circular.mean()),
            optional(band.map(|b| b.0)),
            optional(band.map(|b| b.1)),
            optional(s.divergence_rate),
            s.ns_per_step
        )?;
    }
    Ok(out)
}

fn first_run_csv(summaries: &[Summary]) -> Result<String> {
    let mut out = String::from(
        "method,t,azimuth_error_deg,sigma_a_deg,error_x,sigma_x,error_y,sigma_y,nees_r\n",
    );
    for s in summaries {
        for e in &s.first_run.epochs {
            writeln!(
                out,
                "{},{},{},{},{:.6e},{:.6e},{:.6e},{:.6e},{}",
                s.method.label(),
                e.t,
                optional(e.azimuth_error.map(f64::to_degrees)),
                optional(e.sigma_a.map(f64::to_degrees)),
                e.position_error.x,
                e.position_sigma.x,
                e.position_error.y,
                e.position_sigma.y,
                optional(e.nees)
            )?;
        }
    }
    Ok(out)
}

/// Root means per epoch, with the epoch times of the first run.
fn root_means(series: &liebayes::operators::evaluation::Series) -> Vec<Option<f64>> {
    series
        .means()
        .into_iter()
        .map(|m| m.map(f64::sqrt))
        .collect()
}

fn over_time_csv(summaries: &[Summary]) -> Result<String> {
    let mut out = String::from(
        "method,t,azimuth_rmse_deg,rms_sigma_a_deg,position_rmse,rms_position_sigma\n",
    );
    for s in summaries {
        let (az, sa) = (root_means(&s.azimuth_mse), root_means(&s.mean_sigma_a2));
        let (pos, ps) = (
            root_means(&s.position_mse),
            root_means(&s.mean_position_variance),
        );
        for (k, e) in s.first_run.epochs.iter().enumerate() {
            let at = |v: &[Option<f64>]| v.get(k).copied().flatten();
            writeln!(
                out,
                "{},{},{},{},{},{}",
                s.method.label(),
                e.t,
                optional(at(&az).map(f64::to_degrees)),
                optional(at(&sa).map(f64::to_degrees)),
                optional(at(&pos)),
                optional(at(&ps))
            )?;
        }
    }
    Ok(out)
}

/// Symmetric y range covering every value, at least ±`floor`.
fn symmetric_range(values: impl Iterator<Item = f64>, floor: f64) -> std::ops::Range<f64> {
    let m = values
        .filter(|v| v.is_finite())
        .fold(floor, |m, v| m.max(v.abs()))
        * 1.1;
    -m..m
}

/// The blog post's figure: the first run's azimuth and position errors with the filter's ±1σ bounds.
fn plot_first_run(path: &Path, summary: &Summary) -> Result<()> {
    let run: &Run = &summary.first_run;
    let root = SVGBackend::new(path, (900, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!(
            "{} filter, {} scenario, first run (true azimuth {:.1} deg)",
            summary.method.label(),
            summary.scenario.name(),
            run.true_azimuth.to_degrees()
        ),
        ("sans-serif", 20),
    )?;
    let panels = root.split_evenly((3, 1));
    let t_end = run.epochs.last().map_or(1.0, |e| e.t.max(1.0));
    let rows: [(&str, EpochPick); 3] = [
        ("azimuth error (deg)", |e| {
            (
                e.azimuth_error.map(f64::to_degrees),
                e.sigma_a.map(f64::to_degrees),
            )
        }),
        ("x error (m)", |e| {
            (Some(e.position_error.x), Some(e.position_sigma.x))
        }),
        ("y error (m)", |e| {
            (Some(e.position_error.y), Some(e.position_sigma.y))
        }),
    ];
    for (panel, (label, pick)) in panels.iter().zip(rows) {
        let points: Vec<(f64, f64, f64)> = run
            .epochs
            .iter()
            .filter_map(|e| match pick(e) {
                (Some(v), Some(s)) if v.is_finite() && s.is_finite() => Some((e.t, v, s)),
                _ => None,
            })
            .collect();
        let range = symmetric_range(
            points
                .iter()
                .flat_map(|&(_, v, s)| [v, s.min(4.0 * v.abs().max(1e-3))]),
            1e-3,
        );
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_end, range)?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc(label)
            .draw()?;
        if points.is_empty() {
            chart.draw_series(std::iter::once(Text::new(
                "unobservable: the filter holds the azimuth uniform",
                (0.05 * t_end, 0.0),
                ("sans-serif", 16),
            )))?;
            continue;
        }
        chart
            .draw_series(LineSeries::new(
                points.iter().map(|&(t, v, _)| (t, v)),
                &COLOURS[1],
            ))?
            .label("error")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], COLOURS[1]));
        for sign in [1.0, -1.0] {
            let series = chart.draw_series(LineSeries::new(
                points.iter().map(|&(t, _, s)| (t, sign * s)),
                &COLOURS[2],
            ))?;
            if sign > 0.0 {
                series
                    .label("±1 sigma")
                    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], COLOURS[2]));
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// Azimuth and position RMSE over time for every method (solid), beside the exact filter's RMS σ (dashed
/// black): a consistent filter's RMSE follows its σ.
fn plot_over_time(path: &Path, summaries: &[Summary]) -> Result<()> {
    let root = SVGBackend::new(path, (900, 700)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!(
            "{} scenario: RMSE over {} runs (solid), exact filter's RMS sigma (dashed)",
            summaries[0].scenario.name(),
            summaries[0].runs
        ),
        ("sans-serif", 18),
    )?;
    let panels = root.split_evenly((2, 1));
    let rows: [(&str, f64, SummaryPick); 2] = [
        ("azimuth RMSE (deg)", 180.0 / std::f64::consts::PI, |s| {
            (root_means(&s.azimuth_mse), root_means(&s.mean_sigma_a2))
        }),
        ("position RMSE (m)", 1.0, |s| {
            (
                root_means(&s.position_mse),
                root_means(&s.mean_position_variance),
            )
        }),
    ];
    for (panel, (label, scale, pick)) in panels.iter().zip(rows) {
        let curves: Vec<Curve> = summaries
            .iter()
            .map(|s| {
                let (rmse, sigma) = pick(s);
                let times = s.first_run.epochs.iter().map(|e| e.t);
                let points = |v: &[Option<f64>]| -> Vec<(f64, f64)> {
                    times
                        .clone()
                        .zip(v)
                        .filter_map(|(t, x)| x.map(|x| (t, x * scale)))
                        .filter(|(_, x)| x.is_finite() && *x > 0.0)
                        .collect()
                };
                (s.method.label(), points(&rmse), points(&sigma))
            })
            .collect();
        let all = curves
            .iter()
            .flat_map(|(_, a, b)| a.iter().chain(b).map(|p| p.1));
        let (low, high) = all.fold((f64::INFINITY, 0.0_f64), |(l, h), v| (l.min(v), h.max(v)));
        if !(low.is_finite() && high > 0.0) {
            continue;
        }
        let t_end = summaries[0]
            .first_run
            .epochs
            .last()
            .map_or(1.0, |e| e.t.max(1.0));
        let mut chart = ChartBuilder::on(panel)
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_end, (low * 0.8..high * 1.25).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc(label)
            .y_label_formatter(&|v| {
                if (1e-2..1e3).contains(v) {
                    format!("{v:.2}")
                } else {
                    format!("{v:.0e}")
                }
            })
            .draw()?;
        for (i, (name, rmse, sigma)) in curves.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            chart
                .draw_series(LineSeries::new(rmse.iter().copied(), &colour))?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            if i == 0 {
                chart.draw_series(DashedLineSeries::new(
                    sigma.iter().copied(),
                    6,
                    4,
                    ShapeStyle::from(&colour),
                ))?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()?;
    }
    root.present()?;
    Ok(())
}
