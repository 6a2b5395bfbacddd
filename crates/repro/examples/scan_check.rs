//! Scan vs grid on the loft, cube and Cornell box (and with `MESHES=1` the mesh
//! scenes, the ~10^5-triangle sculpture gallery among them; `ONLY=sculptures_1m` the
//! ~10^6 one): `cargo run --release -p rad-repro --example scan_check`: checks the
//! item buffers are equal and times both (one thread). With `PROFILE=caster`, the
//! time of each patch too (median, 90th percentile, dearest), and the patch ids, for
//! the yardstick's `--ids`.

use rad_accel::{VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_geometry::scenes::{
    blob_room, cornell_box, cube, loft, loft_fine_triangles, loft_patches, loft_triangles,
    sculptures_100k, sculptures_1m, CORNELL_PATCH_MM,
};
use rad_geometry::Scene;
use rad_hemisphere::{
    Caster, FacetScan, Hemisphere, HemisphereConfig, Hierarchy, ItemBuffer, Scan, ScanScratch,
};

fn hs_tests(h: &rad_hemisphere::HierarchyScratch) -> f64 {
    h.scan_stats().tests as f64
}

fn main() {
    let hemi = Hemisphere::new(HemisphereConfig::exact(180, 720)).unwrap();
    // MESHES=1: the mesh scenes too (slower).
    let meshes = std::env::var("MESHES").is_ok_and(|v| v == "1");
    // Built when asked for (the galleries take seconds and gigabytes).
    let mut scenes: Vec<(&str, fn() -> rad_geometry::SceneDesc)> = vec![
        ("loft", loft),
        ("cube", || cube(10)),
        ("cornell", || cornell_box(CORNELL_PATCH_MM)),
    ];
    if meshes {
        scenes.extend([
            ("loft_patches", loft_patches as fn() -> _),
            ("loft_triangles", loft_triangles),
            ("loft_fine", loft_fine_triangles),
            ("blob_room", blob_room),
            ("sculptures_100k", sculptures_100k),
        ]);
    }
    // ONLY=<scene>: that scene alone (sculptures_1m only so).
    let only = std::env::var("ONLY").ok();
    if only.as_deref() == Some("sculptures_1m") {
        scenes.push(("sculptures_1m", sculptures_1m));
    }
    for (name, build) in scenes {
        if only.as_ref().is_some_and(|o| o != name) {
            continue;
        }
        check(name, build(), &hemi);
    }
}

/// `caster` alone on `patches`, ten times over: ms per hemisphere, patches seen a
/// hemisphere, and `stats` of its scratch.
fn profile<C: Caster>(
    name: &str,
    scene: &Scene,
    hemi: &Hemisphere,
    patches: &[u32],
    caster: &C,
    stats: impl Fn(&C::Scratch) -> String,
) {
    let mut s = caster.scratch();
    let mut buf = ItemBuffer::default();
    // Each patch ten times in a row: its time a hemisphere.
    let mut each: Vec<f64> = patches
        .iter()
        .map(|&p| {
            let t = std::time::Instant::now();
            for _ in 0..10 {
                caster.item_buffer(scene, hemi, p, &mut s, &mut buf);
            }
            t.elapsed().as_secs_f64() * 1e3 / 10.0
        })
        .collect();
    let ms = each.iter().sum::<f64>() / each.len() as f64;
    // The dearest and cheapest three, with the polygon each lies on and its distinct
    // patches seen (what makes a hemisphere dear).
    let mut order: Vec<usize> = (0..patches.len()).collect();
    order.sort_by(|&a, &b| each[b].total_cmp(&each[a]));
    let describe = |k: usize, buf: &mut ItemBuffer| {
        let p = patches[k];
        let mut fresh = caster.scratch();
        caster.item_buffer(scene, hemi, p, &mut fresh, buf);
        let mut ids = buf.patch.clone();
        ids.sort_unstable();
        ids.dedup();
        let polygon = scene.polygons()[scene.patches()[p as usize].polygon as usize].name();
        format!(
            "{p} ({polygon}) {:.2} ms, {} seen, {}",
            each[k],
            ids.len(),
            stats(&fresh)
        )
    };
    let ends: Vec<usize> = order[..3]
        .iter()
        .chain(&order[order.len() - 3..])
        .copied()
        .collect();
    for (k, what) in ends
        .iter()
        .zip(["dearest"; 3].iter().chain(&["cheapest"; 3]))
    {
        println!("  {what}: {}", describe(*k, &mut buf));
    }
    each.sort_by(f64::total_cmp);
    // Nearest rank.
    let at = |q: f64| each[((q * (each.len() - 1) as f64).round() as usize).min(each.len() - 1)];
    println!(
        "{name}: per patch median {:.2} ms, 90th percentile {:.2} ms, dearest {:.2} ms; ids {}",
        0.5 * (each[(each.len() - 1) / 2] + each[each.len() / 2]),
        at(0.9),
        at(1.0),
        patches
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(",")
    );
    // With each hemisphere's row summed from its item buffer too (what the yardstick's
    // Embree `p16_full` times).
    let mut acc = rad_hemisphere::RowAccumulator::new(scene.patches().len());
    let t = std::time::Instant::now();
    for _ in 0..10 {
        for &p in patches {
            caster.item_buffer(scene, hemi, p, &mut s, &mut buf);
            std::hint::black_box(hemi.row_from_items(p, &buf, &mut acc));
        }
    }
    let ms_row = t.elapsed().as_secs_f64() * 1e3 / (10 * patches.len()) as f64;
    let mut seen = 0usize;
    for &p in patches {
        caster.item_buffer(scene, hemi, p, &mut s, &mut buf);
        let mut ids = buf.patch.clone();
        ids.sort_unstable();
        ids.dedup();
        seen += ids.len();
    }
    println!(
        "{name}: {ms:.2} ms per hemisphere ({ms_row:.2} ms with its row), {} patches seen a hemisphere ({} in all); {}",
        seen / patches.len(),
        scene.patches().len(),
        stats(&s)
    );
}

/// Every caster against the grid on 32 patches of `desc` (or one caster profiled).
fn check(name: &str, desc: rad_geometry::SceneDesc, hemi: &Hemisphere) {
    let hemi = hemi.clone();
    let scene = Scene::new(desc).unwrap();
    let n = scene.patches().len();
    let patches: Vec<u32> = (0..32).map(|k| ((k * n / 32 + 37) % n) as u32).collect();
    let g = VoxelGrid::build(&scene, &VoxelGridConfig::DEFAULT).unwrap();
    let mut s = g.new_scratch();
    let mut ss = ScanScratch::default();
    let t = std::time::Instant::now();
    let tree = Hierarchy::new(&scene);
    let build = t.elapsed().as_secs_f64();
    let mut hs = tree.scratch();
    let t = std::time::Instant::now();
    let fscan = FacetScan::new(&scene);
    let fbuild = t.elapsed().as_secs_f64();
    let mut fs = fscan.scratch();
    let (mut a, mut b, mut c, mut e) = (
        ItemBuffer::default(),
        ItemBuffer::default(),
        ItemBuffer::default(),
        ItemBuffer::default(),
    );
    if profiled(name, &scene, &hemi, &patches, &tree, &fscan) {
        return;
    }
    let (mut tg, mut ts, mut th, mut tf) = (0.0, 0.0, 0.0, 0.0);
    let (mut bad, mut bad_h, mut bad_f) = (0, 0, 0);
    for &p in &patches {
        let t = std::time::Instant::now();
        hemi.cast(&scene, &g, p, &mut s, &mut a);
        tg += t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        hemi.scan(&scene, p, &mut ss, &mut b);
        ts += t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        tree.item_buffer(&scene, &hemi, p, &mut hs, &mut c);
        th += t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        fscan.item_buffer(&scene, &hemi, p, &mut fs, &mut e);
        tf += t.elapsed().as_secs_f64();
        let differ = |b: &ItemBuffer| {
            (0..a.patch.len())
                .filter(|&k| a.patch[k] != b.patch[k] || a.dist[k].to_bits() != b.dist[k].to_bits())
                .count()
        };
        let (diff, diff_h, diff_f) = (differ(&b), differ(&c), differ(&e));
        if diff_f > 0 {
            bad_f += 1;
            eprintln!("{name} patch {p}: {diff_f} cells differ (facets)");
        }
        if diff > 0 {
            bad += 1;
            eprintln!("{name} patch {p}: {diff} cells differ (scan)");
        }
        if diff_h > 0 {
            bad_h += 1;
            eprintln!("{name} patch {p}: {diff_h} cells differ (hierarchy)");
        }
    }
    let k = patches.len() as f64;
    println!(
        "{name}: grid {:.2} ms, scan {:.2} ms per hemisphere; {:.2} tests/cell, {:.2} full polygons/hemisphere; {bad} differing",
        tg / k * 1e3,
        ts / k * 1e3,
        ss.stats.tests as f64 / ss.stats.hemispheres as f64 / hemi.n_cells() as f64,
        ss.stats.full as f64 / ss.stats.hemispheres as f64
    );
    let h = hs.stats;
    let per = h.hemispheres as f64;
    println!(
        "  hierarchy {:.2} ms per hemisphere ({} nodes, built in {:.1} ms); per hemisphere {:.0} nodes, {:.0} behind, {:.0} occluded, {:.0} polygons; {bad_h} differing",
        th / k * 1e3,
        tree.node_count(),
        build * 1e3,
        h.nodes as f64 / per,
        h.behind as f64 / per,
        h.occluded as f64 / per,
        h.polygons as f64 / per,
    );
    let f = fs.stats;
    let per = f.hemispheres as f64;
    println!(
        "  facets {:.2} ms per hemisphere ({} facets, built in {:.1} ms); per hemisphere {:.1} located, {:.1} one by one, {:.2} tests/cell; {bad_f} differing",
        tf / k * 1e3,
        fscan.facet_count(),
        fbuild * 1e3,
        f.located as f64 / per,
        f.one_by_one as f64 / per,
        fs.scan_stats().tests as f64 / per / hemi.n_cells() as f64,
    );
}

/// Runs one caster alone when `PROFILE` asks for it; false when it does not.
fn profiled(
    name: &str,
    scene: &Scene,
    hemi: &Hemisphere,
    patches: &[u32],
    tree: &Hierarchy,
    fscan: &FacetScan,
) -> bool {
    // PROFILE=facets: the facet scan alone, the same patches ten times; PROFILE=1 (or
    // hierarchy): the hierarchy alone; PROFILE=scan: the polygon scan alone; likewise
    // (for a profiler, and for timing each scene's default caster against Embree).
    match std::env::var("PROFILE").as_deref() {
        Ok("facets") => {
            profile(name, scene, hemi, patches, fscan, |s| {
                let f = s.stats;
                format!(
                    "{:.0} polygons one by one; {:.0} cells located, {:.0} not outside, {:.0} of them given the facet plane's t",
                    f.one_by_one_polygons as f64 / f.hemispheres as f64,
                    f.cells as f64 / f.hemispheres as f64,
                    f.cells_near as f64 / f.hemispheres as f64,
                    f.direct as f64 / f.hemispheres as f64,
                )
            });
            true
        }
        Ok("scan") => {
            profile(name, scene, hemi, patches, &Scan, |s| {
                let per = s.stats.hemispheres as f64;
                format!(
                    "{:.2} tests/cell, {:.0} full polygons",
                    s.stats.tests as f64 / per / hemi.n_cells() as f64,
                    s.stats.full as f64 / per
                )
            });
            true
        }
        Ok("1" | "hierarchy") => {
            profile(name, scene, hemi, patches, tree, |hs| {
                let h = hs.stats;
                let per = h.hemispheres as f64;
                format!("{:.0} nodes, {:.0} occluded, {:.0} polygons, {:.0} flat, {:.0} own, {:.2} tests/cell, {:.0} coplanar skips, {:.0} full", h.nodes as f64 / per, h.occluded as f64 / per, h.polygons as f64 / per, h.flat as f64 / per, h.own as f64 / per, hs_tests(hs) / per / hemi.n_cells() as f64, hs.scan_stats().coplanar_skips as f64 / per, hs.scan_stats().full as f64 / per)
            });
            true
        }
        _ => false,
    }
}
