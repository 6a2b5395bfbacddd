//! Rows shared among processes: parts balanced by work units, rows as bytes, and
//! parts' rows joined equal to one run's, to the bit.

use rad_geometry::{scenes, Scene};
use rad_pipeline::share::{decode_rows, encode_rows, join_rows, shares};
use rad_pipeline::{rows, CasterKind, Hemisphere, HemisphereConfig, Mode, RowMethod};

fn methods() -> [RowMethod; 3] {
    [
        RowMethod::Exact {
            caster: CasterKind::Scan,
        },
        RowMethod::Estimated {
            mode: Mode::Improved,
            centres: CasterKind::Scan,
        },
        RowMethod::Estimated {
            mode: Mode::Faithful,
            centres: CasterKind::Grid,
        },
    ]
}

#[test]
fn shares_cover_the_patches_and_balance_the_lofts_work_within_10_percent() {
    let scene = Scene::new(scenes::loft()).unwrap();
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    for method in methods() {
        for parts in 1..=8 {
            let shares = shares(&scene, method, &all, parts);
            assert_eq!(shares.len(), parts);
            let mut seen: Vec<u32> = shares.iter().flat_map(|s| s.patches.clone()).collect();
            seen.sort();
            assert_eq!(seen, all, "{method:?}, {parts} parts");
            // A share never splits an estimated polygon.
            if method.mode().is_some() {
                let owner = |p: u32| shares.iter().position(|s| s.patches.contains(&p));
                for poly in 0..scene.polygons().len() {
                    let of: Vec<_> = scene
                        .patches()
                        .iter()
                        .enumerate()
                        .filter(|(_, p)| p.polygon as usize == poly)
                        .map(|(k, _)| owner(k as u32))
                        .collect();
                    assert!(of.windows(2).all(|w| w[0] == w[1]), "polygon {poly}");
                }
            }
            let units: Vec<f64> = shares.iter().map(|s| s.units).collect();
            let mean = units.iter().sum::<f64>() / parts as f64;
            let worst = units.iter().cloned().fold(0.0, f64::max);
            if parts <= 4 {
                assert!(worst <= 1.1 * mean, "{method:?}, {parts} parts: {units:?}");
            }
        }
    }
}

#[test]
fn parts_rows_joined_are_one_runs_rows_to_the_bit() {
    let scene = Scene::new(scenes::cornell_box(120.0)).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(12, 48)).unwrap();
    let all: Vec<u32> = (0..scene.patches().len() as u32).collect();
    for method in methods() {
        let whole = rows(&scene, &hemi, method, &all, &|_| {}).unwrap();
        for parts in [2, 3, 5] {
            let made: Vec<_> = shares(&scene, method, &all, parts)
                .iter()
                .map(|s| {
                    let part = rows(&scene, &hemi, method, &s.patches, &|_| {}).unwrap();
                    // Through bytes, as between processes.
                    decode_rows(&encode_rows(&part), method).unwrap()
                })
                .collect();
            let joined = join_rows(method, &all, made).unwrap();
            assert_eq!(joined.rows, whole.rows, "{method:?}, {parts} parts");
            assert_eq!(joined.sources, whole.sources);
            assert_eq!(joined.stats.exact, whole.stats.exact);
            assert_eq!(joined.stats.estimated, whole.stats.estimated);
        }
    }
}

#[test]
fn rows_bytes_that_are_cut_or_padded_are_refused() {
    let scene = Scene::new(scenes::cube(3)).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(6, 24)).unwrap();
    let method = methods()[0];
    let made = rows(&scene, &hemi, method, &[0, 1, 2], &|_| {}).unwrap();
    let bytes = encode_rows(&made);
    assert_eq!(decode_rows(&bytes, method).unwrap().rows, made.rows);
    for cut in [0, 3, 4, 40, bytes.len() / 2, bytes.len() - 1] {
        let e = decode_rows(&bytes[..cut], method).unwrap_err().to_string();
        assert!(e.contains("rows from another process"), "{cut}: {e}");
    }
    let mut long = bytes.clone();
    long.push(0);
    assert!(decode_rows(&long, method)
        .unwrap_err()
        .to_string()
        .contains("left over"));
    let mut huge = bytes;
    huge[4..12].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(decode_rows(&huge, method).is_err());
}

#[test]
fn view_factors_of_shared_rows_are_one_runs_to_the_bit() {
    use rad_pipeline::viewfactors::{
        area_rows, row_patches, view_factors, view_factors_of_rows, Grouping, ViewFactorOptions,
    };
    use rad_pipeline::Enclosure;
    let scene = Scene::new(scenes::cornell_box(120.0)).unwrap();
    let hemi = Hemisphere::new(HemisphereConfig::exact(12, 48)).unwrap();
    for (by, enclosure) in [
        (Grouping::Polygon, Enclosure::Reciprocal),
        (Grouping::Patch, Enclosure::Raw),
    ] {
        let opts = ViewFactorOptions {
            by,
            enclosure,
            ..ViewFactorOptions::for_scene(&scene)
        };
        let whole = view_factors(&scene, &hemi, &opts, &|_| {}).unwrap();
        let ids = row_patches(&scene);
        let method = RowMethod::Exact {
            caster: opts.caster,
        };
        let parts: Vec<_> = shares(&scene, method, &ids, 3)
            .iter()
            .map(|s| {
                let rows = area_rows(&scene, &hemi, &opts, &s.patches, &|_| {}).unwrap();
                let n = rows.len();
                rad_pipeline::Rows {
                    method,
                    rows,
                    sources: vec![None; n],
                    stats: Default::default(),
                }
            })
            .collect();
        let joined = join_rows(method, &ids, parts).unwrap();
        let shared = view_factors_of_rows(&scene, &opts, joined.rows.clone()).unwrap();
        assert_eq!(shared.matrix.rows, whole.matrix.rows, "{by:?}");
        assert_eq!(shared.back, whole.back);
        // Rows not one a patch, in order, are refused.
        assert!(view_factors_of_rows(&scene, &opts, joined.rows[1..].to_vec()).is_err());
    }
}
