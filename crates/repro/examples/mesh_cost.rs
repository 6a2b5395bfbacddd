//! The cost of an estimate on a mesh scene against an exact hemisphere through the
//! scene's default caster (`CasterKind::fastest_for`), one thread, medians (the
//! reproduction's meshes section):
//! `cargo run --release -p rad-repro --example mesh_cost -- loft_fine [180x720] [WINDOWS]`
//! (WINDOWS: how many estimating windows, spread over the scene's; 12 unless given).
use rad_estimator::Schedule;
use rad_geometry::Scene;
use rad_hemisphere::{Hemisphere, HemisphereConfig, Hierarchy};
use rad_pipeline::CasterKind;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("loft_fine", String::as_str);
    let (nt, np) = rad_pipeline::parse_resolution(args.get(2).map_or("180x720", String::as_str))
        .expect("resolution");
    let k: usize = args.get(3).map_or(12, |s| s.parse().expect("a count"));
    let scene = Scene::new(
        rad_repro::meshes::mesh_scene(name)
            .expect("a mesh scene: loft_patches, loft_triangles, loft_fine or blob_room"),
    )
    .expect("a valid scene");
    let tree = Hierarchy::new(&scene);
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np)).expect("a resolution");
    let estimating: Vec<_> = Schedule::of(&scene)
        .windows()
        .iter()
        .filter(|w| !w.estimated.is_empty())
        .cloned()
        .collect();
    let picked: Vec<_> = (0..k)
        .map(|i| estimating[i * estimating.len() / k].clone())
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a pool");
    let kind = CasterKind::fastest_for(&scene);
    let c = pool
        .install(|| rad_repro::meshes::cost_by(&scene, kind, &tree, &hemi, &picked))
        .expect("timed");
    println!(
        "{name} {nt}x{np}: {} estimates; exact ({}) {:.2} ms, improved {:.2} ms ({:.3}), faithful {:.2} ms ({:.3})",
        c.hemispheres, kind.name(), c.median_ms_exact, c.median_ms_improved, c.ratio_improved, c.median_ms_faithful, c.ratio_faithful
    );
}
