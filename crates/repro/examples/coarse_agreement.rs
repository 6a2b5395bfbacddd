//! A fine scene's solution against a coarse scene's of the same geometry, polygon by
//! polygon of the coarse scene: each fine patch goes to the coarse polygon that holds
//! its centre (same plane, same facing), and the two area-weighted mean radiosities of
//! each coarse polygon are compared (luminance, relative to the coarse one), each
//! patch's radiosity with its solution's ambient term as a render shows it
//! (`B + ρ · ambient`: shooting's unshot light). Prints the median and largest
//! differences, the polygons over 2 %, and the twelve worst with their areas and means.
//!
//! `cargo run --release -p rad-repro --example coarse_agreement -- COARSE.json
//! COARSE_SOLUTION.json FINE.json FINE_SOLUTION.json`

use rad_pipeline::solve::read_solution;
use rad_pipeline::SceneFile;

fn luminance(b: [f64; 3]) -> f64 {
    0.2126 * b[0] + 0.7152 * b[1] + 0.0722 * b[2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [coarse, coarse_sol, fine, fine_sol] = &args[..] else {
        return Err(
            "usage: coarse_agreement COARSE.json COARSE_SOL.json FINE.json FINE_SOL.json".into(),
        );
    };
    let coarse = SceneFile::load(coarse.as_ref(), None)?;
    let fine = SceneFile::load(fine.as_ref(), None)?;
    let shown =
        |path: &str, scene: &SceneFile| -> Result<Vec<[f64; 3]>, Box<dyn std::error::Error>> {
            let b = read_solution(path.as_ref(), scene)?;
            let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path)?)?;
            let ambient: [f64; 3] = serde_json::from_value(json["ambient"].clone())?;
            Ok(b.iter()
                .enumerate()
                .map(|(i, b)| {
                    let rho = scene.scene.patch_material(i as u32).reflectance.0;
                    std::array::from_fn(|c| b[c] + rho[c] * ambient[c])
                })
                .collect())
        };
    let bc = shown(coarse_sol, &coarse)?;
    let bf = shown(fine_sol, &fine)?;
    let polys = coarse.scene.polygons();
    // Per coarse polygon: (area, area x luminance) of the coarse and the fine solution.
    let mut sums = vec![[0.0f64; 4]; polys.len()];
    for (p, b) in coarse.scene.patches().iter().zip(&bc) {
        let s = &mut sums[p.polygon as usize];
        s[0] += p.area;
        s[1] += p.area * luminance(*b);
    }
    let scale = polys
        .iter()
        .flat_map(|p| p.vertices())
        .fold(0.0f32, |m, v| m.max(v.abs().max_element()));
    let mut unplaced = 0usize;
    for (p, b) in fine.scene.patches().iter().zip(&bf) {
        let home = polys.iter().position(|q| {
            q.normal().dot(p.normal) > 0.999 && q.plane_num(p.center).abs() <= 1e-4 * scale && {
                let (u, v) = q.uv(p.center);
                q.contains_uv(u, v)
            }
        });
        let Some(k) = home else {
            unplaced += 1;
            continue;
        };
        sums[k][2] += p.area;
        sums[k][3] += p.area * luminance(*b);
    }
    let mut diffs: Vec<(f64, usize)> = sums
        .iter()
        .enumerate()
        .filter(|(_, s)| s[0] > 0.0 && s[2] > 0.0 && s[1] > 0.0)
        .map(|(k, s)| (((s[3] / s[2]) / (s[1] / s[0]) - 1.0).abs(), k))
        .collect();
    diffs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = diffs.len();
    let over = diffs.iter().filter(|d| d.0 > 0.02).count();
    let area_over: f64 = diffs
        .iter()
        .filter(|d| d.0 > 0.02)
        .map(|d| sums[d.1][0])
        .sum();
    let area_fine: f64 = sums.iter().map(|s| s[2]).sum();
    let area_coarse: f64 = sums.iter().map(|s| s[0]).sum();
    println!(
        "coarse polygons compared {n} of {}; fine patches not placed {unplaced}; areas placed {area_fine:.6} of {area_coarse:.6}",
        polys.len()
    );
    println!(
        "relative difference of each polygon's mean luminance: median {:.5}, max {:.5} (polygon {}), over 2 %: {over} ({:.1} % of the area)",
        diffs[n / 2].0,
        diffs[n - 1].0,
        diffs[n - 1].1,
        100.0 * area_over / area_coarse
    );
    println!("worst: polygon, relative difference, coarse patches' area, coarse luminance, fine luminance");
    for &(d, k) in diffs.iter().rev().take(12) {
        let s = sums[k];
        println!(
            "  {k:4} {d:8.4} {:10.4} {:10.5} {:10.5}",
            s[0],
            s[1] / s[0],
            s[3] / s[2]
        );
    }
    Ok(())
}
