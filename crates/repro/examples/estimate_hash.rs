//! Hash of estimates (both modes) over windows of the bench scenes, to compare two
//! builds bit for bit: `cargo run --release -p rad-repro --example estimate_hash`.
use rad_accel::{VoxelGrid, VoxelGridConfig};
use rad_core::RayCast;
use rad_estimator::{
    windows, Estimator, EstimatorConfig, HoleFill, Mode, Reprojection, SourceHemisphere,
};
use rad_geometry::scenes::{cornell_box, cube, loft, CORNELL_PATCH_MM};
use rad_geometry::Scene;
use rad_hemisphere::{Caster, Hemisphere, HemisphereConfig, Scan};
use std::hash::{Hash, Hasher};

fn main() {
    let config = EstimatorConfig {
        mode: Mode::Improved,
        fill: HoleFill::RingNeighbour,
        reprojection: Reprojection::LATERAL_10,
        boundary_lists: false,
        // Never abandoned, so that every estimate's items are compared.
        max_real_ray_share: 1.0,
        guess_stride: 1,
    };
    for (res, shift) in [((180, 720), 0.0), ((45, 180), 0.5), ((3, 5), 0.0)] {
        let hemi = Hemisphere::new(HemisphereConfig {
            phi_shift: shift,
            ..HemisphereConfig::exact(res.0, res.1)
        })
        .unwrap();
        for (name, desc) in [
            ("loft", loft()),
            ("cube", cube(10)),
            ("cornell", cornell_box(CORNELL_PATCH_MM)),
        ] {
            let scene = Scene::new(desc).unwrap();
            let grid = VoxelGrid::build(&scene, &VoxelGridConfig::DEFAULT).unwrap();
            let mut scratch = grid.new_scratch();
            let all = windows(&scene);
            let est = Estimator::new(&hemi);
            let mut h = std::collections::hash_map::DefaultHasher::new();
            let mut hf = std::collections::hash_map::DefaultHasher::new();
            let mut h3 = std::collections::hash_map::DefaultHasher::new();
            let faithful = EstimatorConfig {
                mode: Mode::Faithful,
                ..config
            };
            let (mut real, mut real3, mut n) = (0, 0, 0);
            let mut e3 = rad_estimator::ImprovedEstimate::default();
            let (mut scan, mut e_scan, mut differ) = (
                Scan.scratch(),
                rad_estimator::ImprovedEstimate::default(),
                0,
            );
            let t = std::time::Instant::now();
            for k in 0..12 {
                let w = &all[(k * 509 + 100) % all.len()];
                let src =
                    SourceHemisphere::cast(&scene, &grid, &hemi, w.centre, false, &mut scratch);
                // The same through the polygon scan (centres and real rays): the same bits.
                let src_scan =
                    SourceHemisphere::cast(&scene, &Scan, &hemi, w.centre, false, &mut scan);
                differ += usize::from(src_scan.items() != src.items());
                for &p in &w.estimated {
                    let mut e = rad_estimator::ImprovedEstimate::default();
                    est.improved(&scene, &grid, &src, p, &config, &mut scratch, &mut e);
                    for stride in [1, 3] {
                        let cfg = EstimatorConfig {
                            guess_stride: stride,
                            ..config
                        };
                        let mut g = rad_estimator::ImprovedEstimate::default();
                        est.improved(&scene, &grid, &src, p, &cfg, &mut scratch, &mut g);
                        est.improved(&scene, &Scan, &src_scan, p, &cfg, &mut scan, &mut e_scan);
                        differ += usize::from(
                            (&g.items, g.holes, g.real_rays)
                                != (&e_scan.items, e_scan.holes, e_scan.real_rays),
                        );
                    }
                    e.items.patch.hash(&mut h);
                    for d in &e.items.dist {
                        d.to_bits().hash(&mut h);
                    }
                    e.holes.hash(&mut h);
                    real += e.real_rays;
                    n += 1;
                    let coarse = EstimatorConfig {
                        guess_stride: 3,
                        ..config
                    };
                    // (Into a reused estimate: the hash checks that reuse too.)
                    est.improved(&scene, &grid, &src, p, &coarse, &mut scratch, &mut e3);
                    let e = &e3;
                    e.items.patch.hash(&mut h3);
                    for d in &e.items.dist {
                        d.to_bits().hash(&mut h3);
                    }
                    e.holes.hash(&mut h3);
                    real3 += e.real_rays;
                    let mut f = rad_estimator::Estimate::default();
                    est.faithful(&scene, &src, p, &faithful, &mut f);
                    f.items.patch.hash(&mut hf);
                    for d in &f.items.dist {
                        d.to_bits().hash(&mut hf);
                    }
                    (f.holes, f.hole_ff.to_bits()).hash(&mut hf);
                }
            }
            println!("{name} {res:?}: {n} estimates, {real} real rays, improved {:016x}, faithful {:016x}, improved /3 {:016x} ({real3} real rays), {differ} differing through the scan, {:.1} ms", h.finish(), hf.finish(), h3.finish(), t.elapsed().as_secs_f64() * 1e3);
        }
    }
}
