//! The mean relative difference of two solutions' images (the report's figure 9
//! measure), rendered from the scene's camera through the same renderer.
//!
//! `cargo run --release -p rad-repro --example image_diff -- SCENE A.json B.json`

use rad_pipeline::images::render_image;
use rad_pipeline::solve::read_solution;
use rad_pipeline::{RenderConfig, SceneFile, Shading, View};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, a, b] = &args[..] else {
        return Err("usage: image_diff SCENE A.json B.json".into());
    };
    let scene = SceneFile::load(scene.as_ref(), None)?;
    let view = View::of_scene(&scene.scene, 640, 480)?;
    let config = RenderConfig {
        samples: 2,
        shading: Shading::Smooth,
    };
    let img = |p: &str| -> Result<_, Box<dyn std::error::Error>> {
        let b = read_solution(p.as_ref(), &scene)?;
        Ok(render_image(&scene.scene, &b, &view, &config)?)
    };
    let (_, d) = rad_render::relative_difference(&img(a)?, &img(b)?)?;
    println!(
        "pixels {} mean {:.5} p99 {:.4} max {:.4} over 10 % {:.5}",
        d.pixels, d.mean, d.p99, d.max, d.over_10_percent
    );
    Ok(())
}
