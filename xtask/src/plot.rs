//! The scaling plot (results/scaling.png): ms a hemisphere against the polygon count,
//! log-log, one line a caster and one an estimator mode, from the reproduction's
//! scaling section. Drawn with `plotters` into memory, its text in the DejaVu Sans font
//! the `dejavu` crate carries (so no system font is needed), encoded with `png`.

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use rad_repro::scaling::Scaling;

const SIZE: (u32, u32) = (960, 640);

/// The plot as PNG bytes.
pub fn scaling_png(s: &Scaling) -> Result<Vec<u8>> {
    plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| anyhow!("the DejaVu font did not load"))?;
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for caster in ["grid", "scan", "hierarchy", "facets"] {
        let points = s.scenes.iter().filter_map(|sc| {
            let t = sc.casters.iter().find(|t| t.caster == caster)?;
            Some((sc.polygons as f64, t.ms_per_hemisphere))
        });
        series.push((format!("exact, {caster}"), points.collect()));
    }
    for mode in ["faithful", "improved"] {
        let points = s.scenes.iter().filter_map(|sc| {
            let m = sc
                .modes
                .iter()
                .find(|m| m.method.starts_with(&format!("estimated/{mode}/")))?;
            Some((sc.polygons as f64, m.ms_per_row))
        });
        series.push((
            format!("rows estimated, {mode} (centres by the default caster)"),
            points.collect(),
        ));
    }
    for (_, points) in &mut series {
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let all = || series.iter().flat_map(|(_, p)| p.iter());
    let (x0, x1) = all().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p.0), hi.max(p.0))
    });
    let (y0, y1) = all().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p.1), hi.max(p.1))
    });
    if !(x0.is_finite() && y0 > 0.0) {
        return Err(anyhow!(
            "the scaling section has no positive figures to plot"
        ));
    }
    let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        let e = |e| anyhow!("drawing the scaling plot: {e:?}");
        root.fill(&WHITE).map_err(e)?;
        let caption = format!(
            "Exact hemispheres as scenes grow ({}x{}, one thread, median ms)",
            s.resolution[0], s.resolution[1]
        );
        let mut chart = ChartBuilder::on(&root)
            .caption(caption, ("sans-serif", 22))
            .margin(20)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (x0 / 2.0..x1 * 2.0).log_scale(),
                (y0 / 2.0..y1 * 2.0).log_scale(),
            )
            .map_err(|e| anyhow!("drawing the scaling plot: {e:?}"))?;
        chart
            .configure_mesh()
            .x_desc("polygons")
            .y_desc("ms a hemisphere (rows: a row)")
            .draw()
            .map_err(|e| anyhow!("drawing the scaling plot: {e:?}"))?;
        let colours = [RED, BLUE, GREEN, BLACK, MAGENTA, CYAN];
        for ((label, points), colour) in series.iter().zip(colours) {
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                .map_err(|e| anyhow!("drawing the scaling plot: {e:?}"))?
                .label(label.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                .map_err(|e| anyhow!("drawing the scaling plot: {e:?}"))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()
            .map_err(|e| anyhow!("drawing the scaling plot: {e:?}"))?;
        root.present()
            .map_err(|e| anyhow!("drawing the scaling plot: {e:?}"))?;
    }
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, SIZE.0, SIZE.1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header()?;
        w.write_image_data(&rgb)?;
    }
    Ok(out)
}
