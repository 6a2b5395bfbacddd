//! Exact hemispheres as scenes grow: milliseconds a hemisphere against the polygon
//! count, for each caster (the voxel grid, the polygon scan, the hierarchy, the facet scan), on the
//! loft and every mesh scene, on one thread; and each estimator mode's rows with their
//! centres through the fastest caster, where the scene has patches to estimate.

use crate::{one_thread, Error};
use rad_accel::VoxelGrid;
use rad_estimator::windows;
use rad_geometry::scenes::{
    blob_room, loft, loft_fine_triangles, loft_patches, loft_triangles, sculptures_100k,
};
use rad_geometry::{Scene, SceneDesc};
use rad_hemisphere::{
    Caster, FacetScan, Hemisphere, HemisphereConfig, Hierarchy, ItemBuffer, Scan,
};
use rad_pipeline::{default_grid, rows, CasterKind, Mode, RowMethod};
use serde::Serialize;
use std::time::Instant;

/// One caster on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct CasterTime {
    pub caster: &'static str,
    /// Median over the patches of one exact item buffer.
    pub ms_per_hemisphere: f64,
    /// Building its structure for the scene (0 for the scan).
    pub build_ms: f64,
}

/// One estimator mode on one scene: the rows of whole windows around the same patches.
#[derive(Clone, Debug, Serialize)]
pub struct ModeTime {
    pub method: String,
    pub rows: usize,
    /// Of which estimated (the others cast exactly: window centres, fallbacks).
    pub estimated: usize,
    /// Thread time a row, rows accumulated, through `rad_pipeline::rows` on one thread.
    pub ms_per_row: f64,
}

/// One scene.
#[derive(Clone, Debug, Serialize)]
pub struct SceneScaling {
    pub scene: &'static str,
    pub polygons: usize,
    pub patches: usize,
    pub hemispheres: usize,
    pub casters: Vec<CasterTime>,
    /// Every caster gave the same item buffers, to the bit, on every patch timed.
    pub identical: bool,
    /// What `coherad` picks for the scene (`CasterKind::fastest_for`).
    pub default_caster: &'static str,
    pub modes: Vec<ModeTime>,
}

/// The scaling section.
#[derive(Clone, Debug, Serialize)]
pub struct Scaling {
    pub resolution: [u32; 2],
    pub scenes: Vec<SceneScaling>,
}

/// The loft and the mesh scenes, the ~10^5-triangle sculpture gallery among them
/// (`quick`: the loft, `loft_patches` and `blob_room`, at 45 × 180, fewer patches).
pub fn run(quick: bool, progress: &(dyn Fn(&str, usize, usize) + Sync)) -> Result<Scaling, Error> {
    let (nt, np, k) = if quick { (45, 180, 6) } else { (180, 720, 24) };
    let hemi = Hemisphere::new(HemisphereConfig::exact(nt, np))?;
    let mut scenes: Vec<(&'static str, fn() -> SceneDesc)> = vec![
        ("loft", loft),
        ("loft_patches", loft_patches),
        ("blob_room", blob_room),
    ];
    if !quick {
        scenes.insert(2, ("loft_triangles", loft_triangles));
        scenes.push(("loft_fine", loft_fine_triangles));
        scenes.push(("sculptures_100k", sculptures_100k));
    }
    let pool = one_thread()?;
    let mut out = Vec::new();
    for (i, (name, build)) in scenes.iter().enumerate() {
        progress("scaling", i, scenes.len());
        let scene = Scene::new(build())?;
        out.push(pool.install(|| scene_scaling(name, &scene, &hemi, k))?);
    }
    progress("scaling", scenes.len(), scenes.len());
    Ok(Scaling {
        resolution: [nt, np],
        scenes: out,
    })
}

/// `k` patches spread over the scene.
fn spread(scene: &Scene, k: usize) -> Vec<u32> {
    let n = scene.patches().len();
    (0..k.min(n))
        .map(|i| ((i * n) / k + n / (2 * k)) as u32)
        .collect()
}

fn scene_scaling(
    name: &'static str,
    scene: &Scene,
    hemi: &Hemisphere,
    k: usize,
) -> Result<SceneScaling, Error> {
    let patches = spread(scene, k);
    let t = Instant::now();
    let grid = VoxelGrid::build(scene, &default_grid())?;
    let grid_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let tree = Hierarchy::new(scene);
    let tree_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let facets = FacetScan::new(scene);
    let facets_ms = t.elapsed().as_secs_f64() * 1e3;
    let (g, g_bufs) = time_caster(scene, hemi, &grid, &patches);
    let (s, s_bufs) = time_caster(scene, hemi, &Scan, &patches);
    let (h, h_bufs) = time_caster(scene, hemi, &tree, &patches);
    let (f, f_bufs) = time_caster(scene, hemi, &facets, &patches);
    let casters = vec![
        CasterTime {
            caster: "grid",
            ms_per_hemisphere: g,
            build_ms: grid_ms,
        },
        CasterTime {
            caster: "scan",
            ms_per_hemisphere: s,
            build_ms: 0.0,
        },
        CasterTime {
            caster: "hierarchy",
            ms_per_hemisphere: h,
            build_ms: tree_ms,
        },
        CasterTime {
            caster: "facets",
            ms_per_hemisphere: f,
            build_ms: facets_ms,
        },
    ];
    let best = CasterKind::fastest_for(scene);
    // Whole windows around the patches, so that estimated rows have their centres.
    let all = windows(scene);
    let mut window_patches = Vec::new();
    for &p in &patches {
        if let Some(w) = all
            .iter()
            .find(|w| w.centre == p || w.estimated.contains(&p))
        {
            if !window_patches.contains(&w.centre) {
                window_patches.push(w.centre);
                window_patches.extend(w.estimated.iter().copied());
            }
        }
    }
    let mut modes = Vec::new();
    for method in [
        RowMethod::Exact { caster: best },
        RowMethod::Estimated {
            mode: Mode::Faithful,
            centres: best,
        },
        RowMethod::Estimated {
            mode: Mode::Improved,
            centres: best,
        },
    ] {
        let t = Instant::now();
        let made = rows(scene, hemi, method, &window_patches, &|_| {})?;
        let seconds = t.elapsed().as_secs_f64();
        modes.push(ModeTime {
            method: method.name(),
            rows: made.rows.len(),
            estimated: made.sources.iter().filter(|s| s.is_some()).count(),
            ms_per_row: seconds * 1e3 / made.rows.len().max(1) as f64,
        });
    }
    Ok(SceneScaling {
        scene: name,
        polygons: scene.polygons().len(),
        patches: scene.patches().len(),
        hemispheres: patches.len(),
        casters,
        identical: g_bufs == s_bufs && g_bufs == h_bufs && g_bufs == f_bufs,
        default_caster: best.name(),
        modes,
    })
}

/// The median ms of one item buffer of each patch through `caster`, and a hash of each
/// buffer (patch ids and distance bits).
fn time_caster<C: Caster>(
    scene: &Scene,
    hemi: &Hemisphere,
    caster: &C,
    patches: &[u32],
) -> (f64, Vec<u64>) {
    let mut scratch = caster.scratch();
    let mut buf = ItemBuffer::default();
    let mut ms = Vec::with_capacity(patches.len());
    let mut hashes = Vec::with_capacity(patches.len());
    for &p in patches {
        let t = Instant::now();
        caster.item_buffer(scene, hemi, p, &mut scratch, &mut buf);
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for (id, d) in buf.patch.iter().zip(&buf.dist) {
            for x in [*id as u64, d.to_bits() as u64] {
                h = (h ^ x).wrapping_mul(0x0100_0000_01b3);
            }
        }
        hashes.push(h);
    }
    ms.sort_by(f64::total_cmp);
    (ms[ms.len() / 2], hashes)
}
