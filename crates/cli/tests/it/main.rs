//! The `coherad` binary end to end: outputs, errors, and no partial files.

use std::path::{Path, PathBuf};
use std::process::Command;

fn coherad(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_coherad"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn bench_scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../bench-scenes")
        .join(name)
}

fn json(out: &std::process::Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is JSON alone")
}

#[test]
fn patches_of_the_cube() {
    let v = json(&coherad(&[
        "patches",
        bench_scene("cube.json").to_str().unwrap(),
    ]));
    let patches = v["patches"].as_array().unwrap();
    assert_eq!(patches.len(), 600);
    let p = &patches[43];
    assert_eq!(p["id"], 43);
    assert_eq!(p["polygon"], 0);
    assert!((p["area"].as_f64().unwrap() - 0.01).abs() < 1e-9);
    assert_eq!(p["corners"].as_array().unwrap().len(), 4);
}

#[test]
fn form_factors_of_some_cube_patches() {
    let scene = bench_scene("cube.json");
    let v = json(&coherad(&[
        "formfactors",
        scene.to_str().unwrap(),
        "--resolution",
        "45x180",
        "--patches",
        "0,43-44",
    ]));
    assert_eq!(v["resolution"], serde_json::json!([45, 180]));
    assert_eq!(v["method"], "exact");
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(
        rows.iter()
            .map(|r| r["patch"].as_u64().unwrap())
            .collect::<Vec<_>>(),
        vec![0, 43, 44]
    );
    for r in rows {
        let sum: f64 = r["entries"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e[1].as_f64().unwrap())
            .sum();
        assert!((sum - 1.0).abs() < 1e-9, "{sum}");
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let scene = bench_scene("loft.json");
    let args = |t: &'static str| {
        [
            "--threads",
            t,
            "formfactors",
            scene.to_str().unwrap(),
            "--resolution",
            "20x80",
            "--patches",
            "0-40,9000-9010",
        ]
        .map(String::from)
    };
    let one = coherad(&args("1").iter().map(String::as_str).collect::<Vec<_>>());
    let two = coherad(&args("2").iter().map(String::as_str).collect::<Vec<_>>());
    assert!(one.status.success() && two.status.success());
    assert_eq!(one.stdout, two.stdout);
}

#[test]
fn scan_and_grid_give_the_same_rows() {
    let scene = bench_scene("cornell.json");
    let run = |caster: &str| {
        coherad(&[
            "formfactors",
            scene.to_str().unwrap(),
            "--resolution",
            "30x120",
            "--patches",
            "0-60,500-520",
            "--caster",
            caster,
        ])
    };
    let (scan, grid) = (run("scan"), run("grid"));
    assert!(scan.status.success() && grid.status.success());
    assert!(json(&scan)["rows"].as_array().unwrap().len() == 82);
    assert_eq!(scan.stdout, grid.stdout);
}

#[test]
fn bad_input_is_a_clear_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rows.json");
    let scene = bench_scene("cube.json");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "formfactors".into(),
                scene.display().to_string(),
                "--resolution".into(),
                "0x720".into(),
            ],
            "resolution",
        ),
        (
            vec![
                "formfactors".into(),
                scene.display().to_string(),
                "--resolution".into(),
                "100000x100000".into(),
            ],
            "over the limit",
        ),
        (
            vec![
                "formfactors".into(),
                scene.display().to_string(),
                "--patches".into(),
                "600".into(),
            ],
            "out of range",
        ),
        (
            vec!["formfactors".into(), "no/such/scene.json".into()],
            "no/such/scene.json",
        ),
    ];
    for (args, needle) in cases {
        let mut args = args;
        args.extend(["--out".to_string(), out.display().to_string()]);
        let r = coherad(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(!r.status.success(), "{args:?} succeeded");
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!out.exists(), "{args:?} left an output file");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "{args:?} left a temporary file"
        );
    }
    // A malformed scene names its file and line.
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{\"materials\": [}").unwrap();
    let r = coherad(&[
        "patches",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(!r.status.success() && err.contains("bad.json:1:"), "{err}");
    assert!(!out.exists());
}

#[test]
fn out_file_is_written_whole() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.json");
    let r = coherad(&[
        "patches",
        bench_scene("cornell.json").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success());
    assert!(r.stdout.is_empty());
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(v["patches"].as_array().unwrap().len() > 100);
}

#[test]
fn estimated_form_factors_name_their_source() {
    let scene = bench_scene("cube.json");
    for estimator in ["faithful", "improved"] {
        let v = json(&coherad(&[
            "formfactors",
            scene.to_str().unwrap(),
            "--resolution",
            "45x180",
            "--patches",
            "0-2,11",
            "--method",
            "estimated",
            "--estimator",
            estimator,
        ]));
        assert_eq!(v["method"], format!("estimated/{estimator}"));
        let rows = v["rows"].as_array().unwrap();
        // Floor cells (0..2, 0) are estimated from their window's centre, cell (1, 1) = patch 11.
        for r in rows {
            let p = r["patch"].as_u64().unwrap();
            if p == 11 {
                assert_eq!(r["source"], "exact");
            } else {
                assert_eq!(r["source"], 11, "patch {p}");
            }
            let sum: f64 = r["entries"]
                .as_array()
                .unwrap()
                .iter()
                .map(|e| e[1].as_f64().unwrap())
                .sum();
            assert!((sum - 1.0).abs() < 1e-9, "{sum}");
        }
    }
}

#[test]
fn solve_then_render_the_cornell_box() {
    let dir = tempfile::tempdir().unwrap();
    let sol = dir.path().join("solution.json");
    let exr = dir.path().join("image.exr");
    let png = dir.path().join("image.png");
    let scene = bench_scene("cornell.json");
    let s = scene.display().to_string();
    for solver in ["gauss-seidel", "progressive"] {
        let out = coherad(&[
            "solve",
            &s,
            "--resolution",
            "20x80",
            "--solver",
            solver,
            "--out",
            sol.to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&sol).unwrap()).unwrap();
        assert_eq!(v["solver"]["solver"], solver);
        assert_eq!(v["solver"]["converged"], true);
        let imbalance = v["solver"]["energy"]["relative_imbalance"]
            .as_f64()
            .unwrap();
        assert!(imbalance < 1e-6, "{imbalance}");
        let b = v["radiosity"].as_array().unwrap();
        assert_eq!(b.len() as u64, v["n_patches"].as_u64().unwrap());
    }
    let out = coherad(&[
        "render",
        &s,
        "--solution",
        sol.to_str().unwrap(),
        "--out",
        exr.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--width",
        "40",
        "--height",
        "30",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let exr_bytes = std::fs::read(&exr).unwrap();
    assert_eq!(&exr_bytes[..4], &[0x76, 0x2f, 0x31, 0x01], "EXR magic");
    let png_bytes = std::fs::read(&png).unwrap();
    assert_eq!(&png_bytes[1..4], b"PNG");

    bad_renders_and_solves(&dir, &s, &sol);
}

/// What `render` and `solve` refuse, given the Cornell box `s` and its solution `sol`.
fn bad_renders_and_solves(dir: &tempfile::TempDir, s: &str, sol: &Path) {
    let other = dir.path().join("other.exr");
    // Another scene's solution is refused, and nothing is written: the cube, and the
    // same Cornell box but for one reflectance (the same patches).
    let copy = dir.path().join("cornell-copy.json");
    let text = std::fs::read_to_string(s).unwrap();
    assert!(text.contains("0.725"), "the white reflectance");
    std::fs::write(&copy, text.replacen("0.725", "0.724", 1)).unwrap();
    // The same scene under another description is the same scene.
    let renamed = dir.path().join("cornell-renamed.json");
    let described = text.replacen("\"description\": \"", "\"description\": \"A copy: ", 1);
    std::fs::write(&renamed, described).unwrap();
    let out = coherad(&[
        "render",
        renamed.to_str().unwrap(),
        "--solution",
        sol.to_str().unwrap(),
        "--out",
        other.to_str().unwrap(),
        "--width",
        "40",
        "--height",
        "30",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    std::fs::remove_file(&other).unwrap();
    for scene in [bench_scene("cube.json"), copy] {
        let out = coherad(&[
            "render",
            &scene.display().to_string(),
            "--solution",
            sol.to_str().unwrap(),
            "--out",
            other.to_str().unwrap(),
        ]);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("made for another scene"), "{err}");
        assert!(!other.exists());
    }
    let s = &s.to_string();
    // A missing solution file names itself.
    let out = coherad(&[
        "render",
        &s,
        "--solution",
        "no/such.json",
        "--out",
        other.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such.json"));
    // Impossible sizes and tolerances are refused.
    let out = coherad(&[
        "render",
        &s,
        "--solution",
        sol.to_str().unwrap(),
        "--out",
        other.to_str().unwrap(),
        "--width",
        "0",
    ]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("image size 0x480"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = coherad(&[
        "solve",
        &s,
        "--resolution",
        "8x32",
        "--tolerance=-1",
        "--out",
        other.to_str().unwrap(),
    ]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("tolerance"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Shooting on raw rows cannot converge: refused before any work.
    let out = coherad(&[
        "solve",
        &s,
        "--raw",
        "--solver",
        "progressive",
        "--out",
        other.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--raw with --solver progressive"),
        "{err}"
    );
    // An exposure needs a PNG, and is checked before rendering: no EXR is left.
    let out = coherad(&[
        "render",
        &s,
        "--solution",
        sol.to_str().unwrap(),
        "--out",
        other.to_str().unwrap(),
        "--exposure",
        "2",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("give --png too"),
        "{err}"
    );
    assert!(!other.exists());
}

/// FNV-1a (64 bits) of `bytes`.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// `coherad formfactors` writes the same bytes as it did before the caster interface
/// and the pipeline crate (hashes stored from the binary at 4538061), for exact rows
/// through both casters and estimated rows in both modes with centres through both.
/// The loft's were stored again when rows came to be made from the scene divided by
/// its largest coordinate (12): 28 of 8,294,400 cells of 64 hemispheres see
/// another patch, one cell's 1.2e-5 at most (`cargo run --release -p rad-repro
/// --example divided_rows`); the unit cube's, divided by 1, are the same bytes.
#[test]
fn form_factor_files_keep_their_stored_hashes() {
    let cases = [
        ("cube.json", "all", "exact", 0xfdd8_c8ad_704d_ab3a_u64),
        (
            "cube.json",
            "all",
            "estimated/faithful",
            0x600c_2885_d23d_6ff8,
        ),
        (
            "cube.json",
            "all",
            "estimated/improved",
            0x026d_9ad2_3ba8_957e,
        ),
        ("loft.json", "0-1499", "exact", 0x3d2e_142e_736f_7ee8),
        (
            "loft.json",
            "0-1499",
            "estimated/faithful",
            0xcf48_c2d3_2cb2_dc39,
        ),
        (
            "loft.json",
            "0-1499",
            "estimated/improved",
            0x3f2e_db8e_4b6b_e7fe,
        ),
    ];
    for (scene, patches, method, want) in cases {
        let scene = bench_scene(scene);
        for caster in ["scan", "grid"] {
            let mut args = vec![
                "formfactors",
                scene.to_str().unwrap(),
                "--resolution",
                "45x180",
                "--patches",
                patches,
                "--caster",
                caster,
            ];
            if let Some(mode) = method.strip_prefix("estimated/") {
                args.extend(["--method", "estimated", "--estimator", mode]);
            }
            let out = coherad(&args);
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            assert_eq!(
                fnv1a(&out.stdout),
                want,
                "{} {patches} {method} through the {caster}",
                scene.display()
            );
        }
    }
}

/// The unit cube scaled to 1e30 or 1e-30 is refused with the polygon and the limit (it
/// used to be solved into `null` radiosities, or zeros), and nothing is written.
#[test]
fn scenes_beyond_the_numeric_range_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(bench_scene("cube.json")).unwrap();
    let mut cube: serde_json::Value = serde_json::from_str(&text).unwrap();
    cube.as_object_mut().unwrap().remove("camera");
    for (k, want) in [(1e30, "beyond 1e18"), (1e-30, "under the 1e-12")] {
        let mut scaled = cube.clone();
        for p in scaled["polygons"].as_array_mut().unwrap() {
            for v in p["vertices"].as_array_mut().unwrap() {
                for c in v.as_array_mut().unwrap() {
                    *c = serde_json::json!(c.as_f64().unwrap() * k);
                }
            }
        }
        let path = dir.path().join(format!("cube-{k:e}.json"));
        std::fs::write(&path, scaled.to_string()).unwrap();
        let out_file = dir.path().join("solution.json");
        let out = coherad(&[
            "solve",
            path.to_str().unwrap(),
            "--resolution",
            "8x32",
            "--out",
            out_file.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(want) && err.contains("polygon 0"),
            "{err}"
        );
        assert!(!out_file.exists());
    }
}

/// `coherad viewfactors`: the cube's face factors as Matrix Market (chosen by the
/// extension), closed; bad flags refused with nothing written.
#[test]
fn view_factors_of_the_cube() {
    let dir = tempfile::tempdir().unwrap();
    let scene = bench_scene("cube.json");
    let out = dir.path().join("cube.mtx");
    let run = coherad(&[
        "viewfactors",
        scene.to_str().unwrap(),
        "--resolution",
        "45x180",
        "--enclosure",
        "closed",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("%%MatrixMarket matrix coordinate real general\n"));
    let mut sums = [0.0f64; 6];
    let mut lines = text.lines().filter(|l| !l.starts_with('%'));
    assert_eq!(lines.next().unwrap(), "6 6 30");
    for l in lines {
        let t: Vec<&str> = l.split_whitespace().collect();
        let (i, j, f): (usize, usize, f64) = (
            t[0].parse().unwrap(),
            t[1].parse().unwrap(),
            t[2].parse().unwrap(),
        );
        assert_ne!(i, j);
        sums[i - 1] += f;
    }
    for s in sums {
        assert!((s - 1.0).abs() < 1e-9, "{sums:?}");
    }
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("enclosure closed"), "{stderr}");

    for (args, says) in [
        (vec!["--origins", "0"], "--origins 0 is invalid"),
        (
            vec!["--origins", "257"],
            "--origins 257 is invalid: give 1 to 256",
        ),
        (vec!["--by", "group"], "belongs to no group"),
        (
            vec!["--by", "patch", "--format", "csv"],
            "a dense csv table of 14400 surfaces",
        ),
    ] {
        let bad = dir.path().join("bad.json");
        // The last case on the loft (14,400 patches): refused before any work.
        let on = if args.contains(&"csv") {
            bench_scene("loft.json")
        } else {
            scene.clone()
        };
        let on = on.to_str().unwrap().to_string();
        let mut all = vec!["viewfactors", on.as_str(), "--resolution", "9x36"];
        all.extend(args);
        all.extend(["--out", bad.to_str().unwrap()]);
        let r = coherad(&all);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success() && stderr.contains(says), "{stderr}");
        assert!(!bad.exists());
    }
    // A binary file goes to a file, not a terminal.
    let r = coherad(&["viewfactors", scene.to_str().unwrap(), "--format", "bin"]);
    assert!(!r.status.success() && r.stdout.is_empty());
    assert!(String::from_utf8_lossy(&r.stderr).contains("give --out FILE.bin"));
    // Patch to patch, raw, streamed: the file reads back with the cube's 600 areas.
    let bin = dir.path().join("cube.bin");
    let r = coherad(&[
        "viewfactors",
        scene.to_str().unwrap(),
        "--by",
        "patch",
        "--origins",
        "1",
        "--resolution",
        "9x36",
        "--out",
        bin.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let bytes = std::fs::read(&bin).unwrap();
    assert_eq!(&bytes[..8], b"COHERADM");
    assert_eq!(u64::from_le_bytes(bytes[16..24].try_into().unwrap()), 600);
    assert_eq!(&bytes[bytes.len() - 16..bytes.len() - 8], b"COHERADE");
}

/// The pixels of an EXR file (RGB, row by row).
fn exr_pixels(path: &Path) -> Vec<[f32; 3]> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            let w = resolution.width();
            (w, vec![[0.0f32; 3]; w * resolution.height()])
        },
        |(w, pixels): &mut (usize, Vec<[f32; 3]>),
         position,
         (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[position.y() * *w + position.x()] = [r, g, b];
        },
    )
    .unwrap();
    image.layer_data.channel_data.pixels.1
}

/// An OBJ scene has no camera: `render` takes one from flags, and `--radiance` writes
/// B / pi.
#[test]
fn render_an_obj_scene_with_camera_flags_and_radiance() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("box.obj");
    std::fs::write(
        dir.path().join("box.mtl"),
        "newmtl white\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0.5 0.5 0.5\nKe 5 5 5\n",
    )
    .unwrap();
    std::fs::write(
        &obj,
        "mtllib box.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
         usemtl white\nf 1 5 6 2\nf 1 4 8 5\nf 2 6 7 3\nf 1 2 3 4\nf 5 8 7 6\nusemtl lamp\nf 4 3 7 8\n",
    )
    .unwrap();
    let (o, sol) = (obj.to_str().unwrap(), dir.path().join("box.solution.json"));
    let solved = coherad(&[
        "solve",
        o,
        "--patch-size",
        "0.25",
        "--resolution",
        "20x80",
        "--out",
        sol.to_str().unwrap(),
    ]);
    assert!(
        solved.status.success(),
        "{}",
        String::from_utf8_lossy(&solved.stderr)
    );
    let render = |extra: &[&str], out: &Path| {
        let mut args = vec![
            "render",
            o,
            "--patch-size",
            "0.25",
            "--solution",
            sol.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "64",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        coherad(&args)
    };
    let none = dir.path().join("none.exr");
    let r = render(&[], &none);
    assert!(!r.status.success() && !none.exists());
    assert!(String::from_utf8_lossy(&r.stderr)
        .contains("has no camera: give --eye X,Y,Z and --look-at X,Y,Z"));
    let bad = render(&["--eye", "0.5,0.5", "--look-at", "0.5,0.5,1"], &none);
    assert!(String::from_utf8_lossy(&bad.stderr)
        .contains("--eye \"0.5,0.5\": give three finite numbers"));
    let cam = [
        "--eye",
        "0.5,0.5,0.05",
        "--look-at",
        "0.5,0.5,1",
        "--fov",
        "80",
    ];
    let (b_path, l_path) = (dir.path().join("b.exr"), dir.path().join("l.exr"));
    let r = render(&cam, &b_path);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let mut with = cam.to_vec();
    with.push("--radiance");
    assert!(render(&with, &l_path).status.success());
    let (b, l) = (exr_pixels(&b_path), exr_pixels(&l_path));
    assert_eq!(b.len(), 64 * 64);
    let lit = b.iter().filter(|p| p[0] > 0.0).count();
    assert!(
        lit > 64 * 60,
        "{lit} lit pixels: the camera looks into the box"
    );
    for (p, q) in b.iter().zip(&l) {
        for c in 0..3 {
            let want = p[c] / std::f32::consts::PI;
            assert!(
                (q[c] - want).abs() <= 1e-6 * p[c].abs().max(1e-30),
                "{} vs {want}",
                q[c]
            );
        }
    }
}

#[test]
fn a_ply_box_with_a_concave_face_and_a_material_file_solves_and_exports() {
    // A closed unit box as PLY, every face facing in: its top (y = 1) is an L-shaped
    // hexagon (concave, refused without --triangulate) and the square in its notch, the
    // lamp, named by the material file's box rule; a degenerate sliver besides.
    let dir = tempfile::tempdir().unwrap();
    let vertices = [
        [0., 0., 0.],
        [1., 0., 0.],
        [1., 1., 0.],
        [0., 1., 0.],
        [0., 0., 1.],
        [1., 0., 1.],
        [1., 1., 1.],
        [0., 1., 1.],
        [0.5, 1., 0.],
        [0.5, 1., 0.5],
        [0., 1., 0.5],
        [1., 1., 0.5],
    ];
    let faces = [
        "4 0 4 5 1",      // y = 0
        "4 0 3 7 4",      // x = 0
        "4 1 5 6 2",      // x = 1
        "4 0 1 2 3",      // z = 0
        "4 4 7 6 5",      // z = 1
        "6 3 8 9 11 6 7", // y = 1: the L, concave at vertex 9
        "4 8 2 11 9",     // y = 1: the lamp, [0.5, 1] x [0, 0.5] in x, z
        "3 0 1 1",        // a degenerate sliver
    ];
    let mut ply = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        faces.len()
    );
    for p in &vertices {
        ply.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
    }
    for f in faces {
        ply.push_str(f);
        ply.push('\n');
    }
    let path = dir.path().join("box.ply");
    std::fs::write(&path, ply).unwrap();
    let map = dir.path().join("materials.json");
    std::fs::write(
        &map,
        r#"{"materials": [{"name": "lamp", "reflectance": [0, 0, 0], "emission": [10, 10, 10]}],
            "assign": [{"material": "lamp", "inside": {"min": [0.49, 0.99, -0.01], "max": [1.01, 1.01, 0.51]}}]}"#,
    )
    .unwrap();
    let p = path.to_str().unwrap();
    let base = ["--patch-size", "0.25", "--materials", map.to_str().unwrap()];
    let refused = coherad(&[&["patches", p][..], &base].concat());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && err.contains("box.ply") && err.contains("--triangulate"),
        "{err}"
    );
    let sol = dir.path().join("s.json");
    let s = sol.to_str().unwrap();
    let solve = coherad(
        &[
            &[
                "solve",
                p,
                "--triangulate",
                "--resolution",
                "20x80",
                "--out",
                s,
            ][..],
            &base,
        ]
        .concat(),
    );
    let err = String::from_utf8_lossy(&solve.stderr);
    assert!(solve.status.success(), "{err}");
    assert!(
        err.contains("split 1 concave or warped faces into 4 triangles"),
        "{err}"
    );
    assert!(err.contains("dropped 1 degenerate faces"), "{err}");
    assert!(err.contains("material \"lamp\" given to 1 faces"), "{err}");
    let solution: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&sol).unwrap()).unwrap();
    let emitted = solution["solver"]["energy"]["emitted"][0].as_f64().unwrap();
    // The lamp is 0.25 m² at 10 W/m².
    assert!((emitted - 2.5).abs() < 1e-9, "{emitted}");
    let glb = dir.path().join("box.glb");
    let g = glb.to_str().unwrap();
    let export = coherad(
        &[
            &[
                "export",
                p,
                "--triangulate",
                "--solution",
                s,
                "--exposure=-2",
                "--out",
                g,
            ][..],
            &base,
        ]
        .concat(),
    );
    let err = String::from_utf8_lossy(&export.stderr);
    assert!(export.status.success() && err.contains("EV -2.00"), "{err}");
    assert_eq!(&std::fs::read(&glb).unwrap()[..4], b"glTF");
}

/// The long options listed under "Options:" in a `--help` text.
fn flags_of(help: &str) -> Vec<String> {
    let mut flags = Vec::new();
    let mut in_options = false;
    for line in help.lines() {
        if line.trim().is_empty() {
            // clap's long help puts blank lines between options: not the section's end.
            continue;
        }
        if line.ends_with(':') && !line.starts_with(' ') {
            // A section heading: "Options:", or a custom one (a help_heading).
            in_options = line != "Commands:" && line != "Arguments:";
            continue;
        }
        if !line.starts_with(' ') {
            in_options = false;
        }
        let t = line.trim_start();
        if in_options && t.starts_with('-') {
            if let Some(pos) = t.find("--") {
                let flag: String = t[pos..]
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                    .collect();
                if flag != "--help" && flag != "--version" {
                    flags.push(flag);
                }
            }
        }
    }
    flags
}

#[test]
fn the_cli_reference_lists_every_command_and_flag_that_help_does() {
    let page =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/cli.md"))
            .unwrap();
    let start = page
        .find("## The `coherad` tool")
        .expect("docs/cli.md's coherad section");
    let section = &page[start..];
    let section = &section[..section[3..].find("\n## ").map_or(section.len(), |k| k + 3)];
    let top = String::from_utf8(coherad(&["--help"]).stdout).unwrap();
    let commands: Vec<String> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect();
    assert!(commands.len() >= 6, "{top}");
    let global = flags_of(&top);
    assert!(global.contains(&"--quiet".to_string()), "{global:?}");
    for flag in &global {
        assert!(
            section.contains(flag.as_str()),
            "docs/cli.md: the global flag {flag} is not documented"
        );
    }
    for cmd in &commands {
        let key = format!("- `{cmd} ");
        let at = section
            .find(&key)
            .unwrap_or_else(|| panic!("docs/cli.md: no bullet for `{cmd}`"));
        let bullet = &section[at..];
        let bullet = &bullet[..bullet[1..].find("\n- `").map_or(bullet.len(), |k| k + 1)];
        let help = String::from_utf8(coherad(&[cmd, "--help"]).stdout).unwrap();
        let own: Vec<String> = flags_of(&help)
            .into_iter()
            .filter(|f| !global.contains(f))
            .collect();
        assert!(
            !own.is_empty(),
            "`{cmd} --help` lists no flags of its own:\n{help}"
        );
        for flag in &own {
            assert!(
                bullet.contains(flag.as_str()),
                "docs/cli.md: `{cmd}`'s bullet does not mention {flag}"
            );
        }
    }
}

#[test]
fn exit_codes_tell_errors_usage_and_unconverged_solves_apart() {
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(
        coherad(&["patches", "/no/such/scene.json"]).status.code(),
        Some(1)
    );
    assert_eq!(
        coherad(&["patches", "--no-such-flag"]).status.code(),
        Some(2)
    );
    assert_eq!(
        coherad(&["--threads", "0", "patches", "x.json"])
            .status
            .code(),
        Some(2)
    );
    let out = dir.path().join("s.json");
    let cornell = bench_scene("cornell.json");
    // Gauss-Seidel stopped after two sweeps, far from its tolerance.
    let r = coherad(&[
        "solve",
        cornell.to_str().unwrap(),
        "--resolution",
        "30x120",
        "--max-iterations",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(3), "{err}");
    assert!(err.contains("did not converge") && out.exists(), "{err}");
    let ok = coherad(&[
        "--quiet",
        "solve",
        cornell.to_str().unwrap(),
        "--resolution",
        "30x120",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(ok.status.code(), Some(0));
    assert!(
        ok.stderr.is_empty(),
        "--quiet: {}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let v = coherad(&["--version"]);
    let text = String::from_utf8_lossy(&v.stdout);
    assert!(v.status.success() && text.contains("(git "), "{text}");
}

#[test]
fn runs_killed_while_writing_leave_no_partial_output() {
    // 20 runs killed (SIGKILL) at spread-out moments while computing or writing: the
    // output is absent or whole, never partial; the next run clears their temporaries.
    let dir = tempfile::tempdir().unwrap();
    let loft = bench_scene("loft.json");
    let out = dir.path().join("out.json");
    let mut complete = 0;
    for k in 0..20u64 {
        let _ = std::fs::remove_file(&out);
        let args: Vec<String> = if k % 2 == 0 {
            [
                "formfactors",
                loft.to_str().unwrap(),
                "--resolution",
                "30x120",
                "--out",
            ]
        } else {
            [
                "solve",
                loft.to_str().unwrap(),
                "--resolution",
                "20x80",
                "--out",
            ]
        }
        .iter()
        .map(|s| s.to_string())
        .chain([out.to_str().unwrap().to_string()])
        .collect();
        let mut child = Command::new(env!("CARGO_BIN_EXE_coherad"))
            .args(&args)
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        // Moments from 30 ms to about 3 s, spread by a fixed sequence.
        let wait = 30 + (k * 7919 % 20) * 150;
        std::thread::sleep(std::time::Duration::from_millis(wait));
        let _ = child.kill();
        let _ = child.wait();
        if out.exists() {
            let text = std::fs::read_to_string(&out).unwrap();
            let v: serde_json::Value = serde_json::from_str(&text)
                .unwrap_or_else(|e| panic!("run {k}: a partial output ({e})"));
            let key = if k % 2 == 0 { "rows" } else { "radiosity" };
            assert_eq!(v[key].as_array().unwrap().len(), 14400, "run {k}");
            complete += 1;
        }
    }
    // A run to the end clears the killed runs' temporaries.
    let ok = coherad(&[
        "formfactors",
        loft.to_str().unwrap(),
        "--resolution",
        "6x24",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok.status.success());
    let strays: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(strays.is_empty(), "{strays:?}");
    // Some runs were cut short (else the test tested nothing).
    assert!(complete < 20, "every run completed before its kill");
}

/// Every number in a JSON value, with the path to it; `null`s where numbers belong
/// (serde writes a non-finite float as `null`) are reported as NaN.
fn numbers(v: &serde_json::Value, path: &str, out: &mut Vec<(String, f64)>) {
    match v {
        serde_json::Value::Number(n) => out.push((path.to_string(), n.as_f64().unwrap())),
        serde_json::Value::Array(a) => {
            let numeric = a.iter().any(|x| x.is_number());
            for (k, x) in a.iter().enumerate() {
                if numeric && x.is_null() {
                    out.push((format!("{path}[{k}]"), f64::NAN));
                }
                numbers(x, &format!("{path}[{k}]"), out);
            }
        }
        serde_json::Value::Object(o) => {
            for (k, x) in o {
                numbers(x, &format!("{path}.{k}"), out);
            }
        }
        _ => {}
    }
}

#[test]
fn no_output_holds_a_nan_an_infinity_or_a_null_number() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["cube.json", "cornell.json", "loft.json"] {
        let scene = bench_scene(name);
        let s = scene.to_str().unwrap();
        let file = |ext: &str| dir.path().join(format!("{name}.{ext}"));
        let (sol, ff, vf) = (file("solution.json"), file("rows.json"), file("vf.json"));
        let (csv, mtx, exr, glb) = (file("vf.csv"), file("vf.mtx"), file("img.exr"), file("glb"));
        let runs: Vec<Vec<&str>> = vec![
            vec![
                "solve",
                s,
                "--resolution",
                "8x32",
                "--out",
                sol.to_str().unwrap(),
            ],
            vec![
                "formfactors",
                s,
                "--resolution",
                "8x32",
                "--out",
                ff.to_str().unwrap(),
            ],
            vec![
                "viewfactors",
                s,
                "--resolution",
                "8x32",
                "--origins",
                "1",
                "--out",
                vf.to_str().unwrap(),
            ],
            vec![
                "viewfactors",
                s,
                "--resolution",
                "8x32",
                "--origins",
                "1",
                "--format",
                "csv",
                "--out",
                csv.to_str().unwrap(),
            ],
            vec![
                "viewfactors",
                s,
                "--resolution",
                "8x32",
                "--origins",
                "1",
                "--out",
                mtx.to_str().unwrap(),
            ],
        ];
        for args in runs {
            let r = coherad(&args);
            assert!(
                r.status.success(),
                "{args:?}: {}",
                String::from_utf8_lossy(&r.stderr)
            );
        }
        let mut render = vec![
            "render",
            s,
            "--solution",
            sol.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "24",
            "--out",
            exr.to_str().unwrap(),
        ];
        if name == "cube.json" {
            render.extend(["--eye", "0.5,0.5,0.5", "--look-at", "0.5,0.5,0"]);
        }
        let r = coherad(&render);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        assert!(coherad(&[
            "export",
            s,
            "--solution",
            sol.to_str().unwrap(),
            "--out",
            glb.to_str().unwrap()
        ])
        .status
        .success());
        let patches = coherad(&["patches", s]);
        for (what, text) in [
            ("patches", String::from_utf8(patches.stdout).unwrap()),
            ("solution", std::fs::read_to_string(&sol).unwrap()),
            ("rows", std::fs::read_to_string(&ff).unwrap()),
            ("view factors", std::fs::read_to_string(&vf).unwrap()),
        ] {
            assert_json_finite(name, what, &text);
        }
        for path in [&csv, &mtx] {
            let text = std::fs::read_to_string(path).unwrap().to_ascii_lowercase();
            assert!(
                !text.contains("nan") && !text.contains("inf"),
                "{}",
                path.display()
            );
        }
        assert!(
            exr_pixels(&exr).iter().flatten().all(|c| c.is_finite()),
            "{name}: the image"
        );
        assert_glb_finite(name, &glb);
    }
}

/// Every number of a JSON output is finite (and there are numbers).
fn assert_json_finite(name: &str, what: &str, text: &str) {
    let v: serde_json::Value = serde_json::from_str(text).unwrap();
    let mut all = Vec::new();
    numbers(&v, what, &mut all);
    assert!(all.len() > 10, "{name} {what}");
    if let Some((path, x)) = all.iter().find(|(_, x)| !x.is_finite()) {
        panic!("{name}: {path} is {x}");
    }
}

/// The GLB's JSON chunk (accessor bounds) parses with finite numbers, and every float
/// of its vertex buffers (positions, normals, colours) is finite.
fn assert_glb_finite(name: &str, glb: &Path) {
    let bytes = std::fs::read(glb).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let mut all = Vec::new();
    numbers(&doc, "glb", &mut all);
    assert!(
        all.iter().all(|(_, x)| x.is_finite()),
        "{name}: the glTF JSON"
    );
    let bin = &bytes[20 + json_len + 8..];
    for view in doc["bufferViews"].as_array().unwrap() {
        if view["target"] == 34962 {
            let (o, l) = (
                view["byteOffset"].as_u64().unwrap() as usize,
                view["byteLength"].as_u64().unwrap() as usize,
            );
            assert!(
                bin[o..o + l]
                    .chunks_exact(4)
                    .all(|c| f32::from_le_bytes(c.try_into().unwrap()).is_finite()),
                "{name}: the glTF buffer"
            );
        }
    }
}

/// The names of the temporaries (`*.tmp`) left in `dir`.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

/// The cube's scene file, and a solution of it written in `dir` (for `render`, `export`).
fn cube_and_solution(dir: &Path) -> (PathBuf, PathBuf) {
    let cube = bench_scene("cube.json");
    let solution = dir.join("cube.solution.json");
    let made = coherad(&[
        "solve",
        cube.to_str().unwrap(),
        "--resolution",
        "10x40",
        "--out",
        solution.to_str().unwrap(),
    ]);
    assert!(made.status.success());
    (cube, solution)
}

/// Every command that writes a file, on the cube, writing `out` (a solution for the
/// cube at `solution`).
fn writing_commands(cube: &str, solution: &str, out: &str, ext: &str) -> Vec<Vec<String>> {
    let list: Vec<Vec<&str>> = match ext {
        "json" => vec![
            vec!["formfactors", cube, "--resolution", "20x80", "--out", out],
            vec!["solve", cube, "--resolution", "20x80", "--out", out],
            vec![
                "viewfactors",
                cube,
                "--by",
                "patch",
                "--resolution",
                "20x80",
                "--out",
                out,
            ],
        ],
        "exr" => vec![vec!["render", cube, "--solution", solution, "--out", out]],
        "glb" => vec![vec!["export", cube, "--solution", solution, "--out", out]],
        "bin" | "mtx" | "csv" => vec![vec![
            "viewfactors",
            cube,
            "--by",
            "patch",
            "--resolution",
            "20x80",
            "--format",
            ext,
            "--out",
            out,
        ]],
        _ => unreachable!(),
    };
    list.into_iter()
        .map(|a| a.into_iter().map(str::to_string).collect())
        .collect()
}

#[test]
fn a_full_disk_is_a_clear_error_that_keeps_the_old_file() {
    // The disk fills at 4 KB: a shell sets the file-size limit (`ulimit -f 8`, in
    // blocks of 512 or 1,024 bytes) and ignores SIGXFSZ, so that writes past it fail
    // with EFBIG as they would with ENOSPC on a full disk; every output is larger.
    let dir = tempfile::tempdir().unwrap();
    let (cube, solution) = cube_and_solution(dir.path());
    for ext in ["json", "exr", "glb", "bin", "mtx", "csv"] {
        let out = dir.path().join(format!("out.{ext}"));
        let (c, s, o) = (
            cube.to_str().unwrap(),
            solution.to_str().unwrap(),
            out.to_str().unwrap(),
        );
        for args in writing_commands(c, s, o, ext) {
            std::fs::write(&out, b"old").unwrap();
            let run = Command::new("/bin/sh")
                .arg("-c")
                .arg("trap '' XFSZ; ulimit -f 8; exec \"$0\" \"$@\"")
                .arg(env!("CARGO_BIN_EXE_coherad"))
                .args(&args)
                .arg("--quiet")
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&run.stderr);
            assert_eq!(run.status.code(), Some(1), "{args:?}: {err}");
            assert!(
                err.contains("cannot write") && err.contains(o) && err.contains("too large"),
                "{args:?}: {err}"
            );
            assert_eq!(std::fs::read(&out).unwrap(), b"old", "{args:?}");
            assert!(temporaries(dir.path()).is_empty(), "{args:?}");
        }
    }
}

#[test]
fn out_of_core_with_a_full_disk_or_no_temporary_folder_is_a_clear_error() {
    // Out-of-core solving writes its rows to an unnamed temporary file: a disk that
    // fills (the file-size limit, as above) or a temporary folder that does not exist
    // is an error naming the folder, with no output and nothing left in the folder.
    let dir = tempfile::tempdir().unwrap();
    let temp = dir.path().join("temp");
    std::fs::create_dir(&temp).unwrap();
    let loft = bench_scene("loft.json");
    let out = dir.path().join("out.json");
    let args = |temp: &Path| -> Vec<String> {
        [
            "solve",
            loft.to_str().unwrap(),
            "--resolution",
            "6x24",
            "--storage",
            "out-of-core",
            "--temp-dir",
            temp.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]
        .map(str::to_string)
        .to_vec()
    };
    let run = Command::new("/bin/sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 8; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_coherad"))
        .args(args(&temp))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(
        err.contains("cannot write a temporary file in")
            && err.contains(temp.to_str().unwrap())
            && err.contains("too large"),
        "{err}"
    );
    assert!(!out.exists());
    assert_eq!(std::fs::read_dir(&temp).unwrap().count(), 0);
    let missing = dir.path().join("no-such-folder");
    let a = args(&missing);
    let run = coherad(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(
        err.contains("cannot create a temporary file in") && err.contains("no-such-folder"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn unwritable_output_folders_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let cube = bench_scene("cube.json");
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let locked = dir.path().join("locked");
    std::fs::create_dir(&locked).unwrap();
    let mut outs = vec![
        (dir.path().join("no/such/folder/out.json"), "No such file"),
        (file.join("out.json"), "Not a directory"),
    ];
    // A read-only folder (unless this runs as root, whom permissions do not stop:
    // probed by writing there first).
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::write(locked.join("probe"), b"").is_err() {
        outs.push((locked.join("out.json"), "Permission denied"));
    }
    for (out, why) in outs {
        let run = coherad(&[
            "formfactors",
            cube.to_str().unwrap(),
            "--resolution",
            "6x24",
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{err}");
        assert!(
            err.contains("cannot write")
                && err.contains(out.to_str().unwrap())
                && err.contains(why),
            "{err}"
        );
    }
    std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn runs_writing_one_output_at_once_leave_one_whole_file() {
    // Four runs of each writing command start together on the same output: each
    // renames a whole file into place, so the output is one of them, to the byte (they
    // are all the same here, but for a solution's timings), and no temporary is left.
    let dir = tempfile::tempdir().unwrap();
    let (cube, solution) = cube_and_solution(dir.path());
    for ext in ["json", "exr", "bin"] {
        let out = dir.path().join(format!("out.{ext}"));
        let (c, s, o) = (
            cube.to_str().unwrap(),
            solution.to_str().unwrap(),
            out.to_str().unwrap(),
        );
        for args in writing_commands(c, s, o, ext) {
            let alone = coherad(&args.iter().map(String::as_str).collect::<Vec<_>>());
            assert!(alone.status.success(), "{args:?}");
            let want = std::fs::read(&out).unwrap();
            std::fs::remove_file(&out).unwrap();
            let children: Vec<_> = (0..4)
                .map(|_| {
                    Command::new(env!("CARGO_BIN_EXE_coherad"))
                        .args(&args)
                        .arg("--quiet")
                        .spawn()
                        .unwrap()
                })
                .collect();
            for mut child in children {
                assert!(child.wait().unwrap().success(), "{args:?}");
            }
            // (A solution records its run's timings: compare the rest.)
            let same = |a: &[u8], b: &[u8]| match (
                serde_json::from_slice::<serde_json::Value>(a),
                serde_json::from_slice::<serde_json::Value>(b),
            ) {
                (Ok(mut x), Ok(mut y)) => {
                    for v in [&mut x, &mut y] {
                        v.as_object_mut().map(|o| o.remove("timings"));
                    }
                    x == y
                }
                _ => a == b,
            };
            let got = std::fs::read(&out).unwrap();
            assert!(same(&got, &want), "{args:?}: the output differs");
            assert!(temporaries(dir.path()).is_empty(), "{args:?}");
        }
    }
}

#[test]
fn a_scene_that_emits_nothing_is_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.json");
    let args = |scene: &str| {
        coherad(&[
            "solve",
            bench_scene(scene).to_str().unwrap(),
            "--resolution",
            "6x24",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let dark = args("cube.json");
    let err = String::from_utf8_lossy(&dark.stderr);
    assert!(
        dark.status.success() && err.contains("no polygon emits light"),
        "{err}"
    );
    let lit = args("cornell.json");
    let err = String::from_utf8_lossy(&lit.stderr);
    assert!(lit.status.success() && !err.contains("emits"), "{err}");
}

mod front_door;
mod motion;
#[cfg(feature = "mpi")]
mod mpi;
mod repair;

/// `--method auto` (solve's default) on a small scene is exact: the same rows, to the
/// byte, as `--method exact`, and no note that it estimates; on loft_triangles (28,800
/// one-patch triangles in flat walls) it says it estimates, and writes estimated rows.
#[test]
fn method_auto_is_exact_on_small_scenes_and_says_when_it_estimates() {
    let cube = bench_scene("cube.json");
    let rows = |method: &str| {
        let out = coherad(&[
            "formfactors",
            cube.to_str().unwrap(),
            "--resolution",
            "12x48",
            "--method",
            method,
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        out
    };
    let (auto, exact) = (rows("auto"), rows("exact"));
    assert_eq!(auto.stdout, exact.stdout);
    assert!(!String::from_utf8_lossy(&auto.stderr).contains("method auto"));
    let mesh = bench_scene("loft_triangles.json");
    let out = coherad(&[
        "formfactors",
        mesh.to_str().unwrap(),
        "--resolution",
        "4x16",
        "--patches",
        "0-99",
        "--method",
        "auto",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains("method auto: estimated rows (28800 patches"),
        "{said}"
    );
    assert_eq!(json(&out)["method"], "estimated/improved");
}

/// Auto's estimated rows give way to exact ones where matrix-free solving is asked for
/// (it casts each shooter's row): a large flat mesh solves, saying so.
#[test]
fn method_auto_makes_exact_rows_for_matrix_free_solving() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.json");
    let mesh = bench_scene("loft_triangles.json");
    let run = coherad(&[
        "solve",
        mesh.to_str().unwrap(),
        "--resolution",
        "4x16",
        "--storage",
        "matrix-free",
        "--tolerance",
        "0.5",
        "--out",
        out.to_str().unwrap(),
    ]);
    let said = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{said}");
    assert!(said.contains("exact rows after all"), "{said}");
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(file["method"], "exact");
    assert_eq!(file["matrix"]["storage"], "matrix-free");
}
