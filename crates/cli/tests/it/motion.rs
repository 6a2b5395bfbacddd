//! `coherad viewfactors --motion` and `coherad solve --motion`: one whole file a step,
//! the first (the scene as written) the very factors or radiosities of a run without
//! motion; bad motions refused by step and group, nothing written; a run killed midway
//! leaves only complete steps.

use super::{bench_scene, coherad};
use std::path::Path;
use std::process::Command;

/// A motion turning the satellite's arrays through `n` steps of 10°.
fn turning(n: usize) -> String {
    let steps: Vec<String> = (0..n)
        .map(|k| {
            let turn = format!(
                r#"{{"rotate": {{"axis": [1, 0, 0], "degrees": {}}}}}"#,
                10 * k
            );
            format!(r#"{{"name": "{k}", "groups": {{"array +x": {turn}, "array -x": {turn}}}}}"#)
        })
        .collect();
    format!(r#"{{"steps": [{}]}}"#, steps.join(", "))
}

fn read(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// `coherad ARGS --out DIR/plain.json` (a run without motion): its file.
fn plain(dir: &Path, args: &[&str]) -> serde_json::Value {
    let out = dir.join("plain.json");
    let mut all = args.to_vec();
    all.extend(["--out", out.to_str().unwrap()]);
    let run = coherad(&all);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    read(&out)
}

fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

#[test]
fn a_motion_writes_one_file_a_step_and_refuses_bad_motions() {
    let dir = tempfile::tempdir().unwrap();
    let sat = bench_scene("satellite.json");
    let sat = sat.to_str().unwrap();
    let motion = dir.path().join("m.json");
    std::fs::write(&motion, turning(3)).unwrap();
    let out = dir.path().join("steps");
    let run = coherad(&[
        "viewfactors",
        sat,
        "--by",
        "group",
        "--resolution",
        "20x80",
        "--motion",
        motion.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert_eq!(
        files(&out),
        ["step_0000.json", "step_0001.json", "step_0002.json"]
    );
    assert!(
        err.contains("step 1 (1): 12 polygons moved") && err.contains("in part"),
        "{err}"
    );
    let first = read(&out.join("step_0000.json"));
    let later = read(&out.join("step_0002.json"));
    assert!(
        later["scene"].as_str().unwrap().ends_with("at step 2 (2)"),
        "{}",
        later["scene"]
    );
    assert_ne!(first["surfaces"], later["surfaces"], "the arrays turned");
    // The first step leaves the scene as written: the factors of a run without motion.
    let whole = plain(
        dir.path(),
        &["viewfactors", sat, "--by", "group", "--resolution", "20x80"],
    );
    assert_eq!(first["surfaces"], whole["surfaces"]);
    assert_eq!(first["scene_hash"], whole["scene_hash"]);
    let plain = dir.path().join("plain.json");

    // Bad motions: named by step and group; no file written.
    for (text, says) in [
        (
            r#"{"steps": [{}, {"name": "deploy", "groups": {"boom": {}}}]}"#,
            "step 1 (\"deploy\") moves group \"boom\"",
        ),
        (
            r#"{"steps": [{"groups": {"bus": {"matrix": [[1.01, 0, 0], [0, 1, 0], [0, 0, 1]]}}}]}"#,
            "scales or shears",
        ),
        (
            r#"{"steps": [{"groups": {"bus": {"matrix": [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]}}}]}"#,
            "reflection",
        ),
        (r#"{"steps": ["#, "m.json:1:"),
        (
            r#"{"steps": [{"name": "into the bus", "groups": {"array +x": {"translate": [-1.8, 0, 0]}}}]}"#,
            "step 0 (\"into the bus\", moving array +x)",
        ),
    ] {
        std::fs::write(&motion, text).unwrap();
        let bad = dir.path().join("bad");
        let run = coherad(&[
            "viewfactors",
            sat,
            "--resolution",
            "8x32",
            "--motion",
            motion.to_str().unwrap(),
            "--out",
            bad.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{text}: {err}");
        assert!(err.contains(says), "{text}: {err}");
        assert!(files(&bad).is_empty(), "{text}: {:?}", files(&bad));
    }
    std::fs::write(&motion, turning(2)).unwrap();
    let run = coherad(&["viewfactors", sat, "--motion", motion.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("give --out FOLDER") && err.contains("FILE.bin"),
        "{err}"
    );
    let run = coherad(&[
        "viewfactors",
        sat,
        "--motion",
        motion.to_str().unwrap(),
        "--out",
        plain.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&run.stderr).contains("is a file"));
}

/// `--out FILE.bin`: every step in one binary file with a step index, each step the
/// matrix the folder's `step_NNNN.bin` holds; a failed run writes no file.
#[test]
fn a_motion_into_one_binary_file_indexes_its_steps() {
    use rad_pipeline::matrix_file::{read_matrix_file, read_matrix_steps};
    let dir = tempfile::tempdir().unwrap();
    let sat = bench_scene("satellite.json");
    let sat = sat.to_str().unwrap();
    let motion = dir.path().join("m.json");
    std::fs::write(&motion, turning(3)).unwrap();
    let run_to = |out: &Path| {
        coherad(&[
            "viewfactors",
            sat,
            "--by",
            "group",
            "--resolution",
            "20x80",
            "--format",
            "bin",
            "--motion",
            motion.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let (file, folder) = (dir.path().join("steps.bin"), dir.path().join("steps"));
    for out in [&file, &folder] {
        let run = run_to(out);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
    }
    let bytes = std::fs::read(&file).unwrap();
    let steps = read_matrix_steps(&bytes, &file).unwrap();
    assert_eq!(steps.len(), 3);
    for (k, step) in steps.iter().enumerate() {
        let one = folder.join(format!("step_{k:04}.bin"));
        assert_eq!(
            *step,
            read_matrix_file(&std::fs::read(&one).unwrap(), &one).unwrap(),
            "step {k}"
        );
    }
    assert_ne!(steps[0].entries, steps[2].entries, "the arrays turned");
    // A `.bin` path ending in a separator is a folder, as before.
    let slash =
        std::path::PathBuf::from(format!("{}/", dir.path().join("as_folder.bin").display()));
    let run = run_to(&slash);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(
        files(&dir.path().join("as_folder.bin")),
        ["step_0000.bin", "step_0001.bin", "step_0002.bin"]
    );
    // Cut short, or an index that points astray: refused by name.
    let cut = read_matrix_steps(&bytes[..bytes.len() - 9], &file).unwrap_err();
    assert!(cut.to_string().contains("truncated"), "{cut}");
    let mut astray = bytes.clone();
    let at = bytes.len() - 16 - 16 * 2;
    astray[at..at + 8].copy_from_slice(&17u64.to_le_bytes());
    let e = read_matrix_steps(&astray, &file).unwrap_err();
    assert!(e.to_string().contains("step 1"), "{e}");
    // A motion refused at step 1, once step 0 is made: no file, and an earlier one
    // left as it was.
    std::fs::write(
        &motion,
        r#"{"steps": [{}, {"name": "into the bus", "groups": {"array +x": {"translate": [-1.8, 0, 0]}}}]}"#,
    )
    .unwrap();
    let run = run_to(&file);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(err.contains("step 1 (\"into the bus\""), "{err}");
    assert_eq!(std::fs::read(&file).unwrap(), bytes);
    let fresh = dir.path().join("fresh.bin");
    assert_eq!(run_to(&fresh).status.code(), Some(1));
    assert!(!fresh.exists());
    assert!(files(dir.path()).iter().all(|f| !f.ends_with(".tmp")));
}

#[test]
fn a_motion_killed_midway_leaves_only_complete_steps() {
    let dir = tempfile::tempdir().unwrap();
    let motion = dir.path().join("m.json");
    std::fs::write(&motion, turning(36)).unwrap();
    let out = dir.path().join("steps");
    let mut child = Command::new(env!("CARGO_BIN_EXE_coherad"))
        .args([
            "viewfactors",
            bench_scene("satellite.json").to_str().unwrap(),
            "--resolution",
            "60x240",
            "--motion",
            motion.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Killed once a few steps are written, while others are being made.
    let start = std::time::Instant::now();
    while files(&out)
        .iter()
        .filter(|f| f.starts_with("step_"))
        .count()
        < 3
        && start.elapsed().as_secs() < 120
    {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let _ = child.kill();
    let _ = child.wait();
    let names = files(&out);
    let steps: Vec<&String> = names.iter().filter(|f| f.starts_with("step_")).collect();
    assert!(steps.len() >= 3 && steps.len() < 36, "{names:?}");
    for (k, name) in steps.iter().enumerate() {
        assert_eq!(
            **name,
            format!("step_{k:04}.json"),
            "steps in order, none missing"
        );
        let text = std::fs::read_to_string(out.join(name)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).expect("a whole file");
        assert!(v["surfaces"].is_array());
    }
}

#[test]
fn a_solve_over_a_motion_writes_a_solution_a_step() {
    let dir = tempfile::tempdir().unwrap();
    let room = bench_scene("room_cart.json");
    let room = room.to_str().unwrap();
    let motion = dir.path().join("m.json");
    let slide = |n: usize| -> String {
        let steps: Vec<String> = (0..n)
            .map(|k| {
                format!(
                    r#"{{"groups": {{"cart": {{"translate": [{}, 0, 0]}}}}}}"#,
                    0.25 * k as f64
                )
            })
            .collect();
        format!(r#"{{"steps": [{}]}}"#, steps.join(", "))
    };
    std::fs::write(&motion, slide(3)).unwrap();
    let out = dir.path().join("steps");
    let run = coherad(&[
        "solve",
        room,
        "--resolution",
        "20x80",
        "--motion",
        motion.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert_eq!(
        files(&out),
        ["step_0000.json", "step_0001.json", "step_0002.json"]
    );
    assert!(
        err.contains("step 1 (step 1): 6 polygons moved")
            && err.contains("sweeps from the step before"),
        "{err}"
    );
    let first = read(&out.join("step_0000.json"));
    let later = read(&out.join("step_0002.json"));
    assert!(
        later["scene"]
            .as_str()
            .unwrap()
            .ends_with("at step 2 (step 2)"),
        "{}",
        later["scene"]
    );
    assert!(later["solver"]["converged"].as_bool().unwrap());
    assert!(
        later["solver"]["energy"]["relative_imbalance"]
            .as_f64()
            .unwrap()
            < 1e-6
    );
    assert_ne!(first["radiosity"], later["radiosity"], "the cart moved");
    // The first step leaves the scene as written: a plain exact solve's radiosities.
    let whole = plain(
        dir.path(),
        &["solve", room, "--resolution", "20x80", "--method", "exact"],
    );
    assert_eq!(first["radiosity"], whole["radiosity"]);
    assert_eq!(first["scene_hash"], whole["scene_hash"]);
    renders_and_exports_each_step(dir.path(), room, &motion, &out);
    // What a motion cannot take is refused before any file is written.
    for (flags, says) in [
        (&["--method", "estimated"][..], "drop --method estimated"),
        (&["--storage", "matrix-free"][..], "--storage stored"),
        (&["--memory-limit", "1K"][..], "raise --memory-limit"),
    ] {
        let bad = dir.path().join("bad");
        let mut args = vec![
            "solve",
            room,
            "--resolution",
            "8x32",
            "--motion",
            motion.to_str().unwrap(),
            "--out",
            bad.to_str().unwrap(),
        ];
        args.extend_from_slice(flags);
        let run = coherad(&args);
        let err = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{flags:?}: {err}");
        assert!(err.contains(says), "{flags:?}: {err}");
        assert!(files(&bad).is_empty(), "{flags:?}: {:?}", files(&bad));
    }
}

/// `render` and `export --motion` over the steps `solve --motion` wrote into `out`.
fn renders_and_exports_each_step(dir: &Path, room: &str, motion: &Path, out: &Path) {
    // Images and glTF files of the steps, each step's solution read against its scene.
    let (m, o) = (motion.to_str().unwrap(), out.to_str().unwrap());
    let images = dir.join("images");
    let run = coherad(&[
        "render",
        room,
        "--motion",
        m,
        "--solution",
        o,
        "--out",
        images.to_str().unwrap(),
        "--png",
        images.to_str().unwrap(),
        "--eye",
        "2.5,1.5,3.9",
        "--look-at",
        "2.5,0.5,0",
        "--width",
        "32",
        "--height",
        "24",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert_eq!(
        files(&images),
        [
            "step_0000.exr",
            "step_0000.png",
            "step_0001.exr",
            "step_0001.png",
            "step_0002.exr",
            "step_0002.png"
        ]
    );
    let gltf = dir.join("gltf");
    let run = coherad(&[
        "export",
        room,
        "--motion",
        m,
        "--solution",
        o,
        "--out",
        gltf.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert_eq!(
        files(&gltf),
        ["step_0000.glb", "step_0001.glb", "step_0002.glb"]
    );
    // (One exposure for every step, so that they compare.)
    let evs: Vec<&str> = err.lines().filter_map(|l| l.split("(EV ").nth(1)).collect();
    assert_eq!(evs.len(), 3, "{err}");
    assert!(evs.iter().all(|e| *e == evs[0]), "{err}");
    // A step's solution read against another step's scene is refused by its hash.
    let swapped = dir.join("swapped");
    std::fs::create_dir(&swapped).unwrap();
    std::fs::copy(out.join("step_0000.json"), swapped.join("step_0000.json")).unwrap();
    std::fs::copy(out.join("step_0000.json"), swapped.join("step_0001.json")).unwrap();
    let run = coherad(&[
        "export",
        room,
        "--motion",
        m,
        "--solution",
        swapped.to_str().unwrap(),
        "--out",
        dir.join("g2").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(
        err.contains("step_0001.json") && err.contains("scene_hash"),
        "{err}"
    );
    // A --solution folder that is not there: refused before any folder is made.
    let none = dir.join("none");
    let run = coherad(&[
        "render",
        room,
        "--motion",
        m,
        "--solution",
        "/no/such/folder",
        "--out",
        none.to_str().unwrap(),
        "--eye",
        "2.5,1.5,3.9",
        "--look-at",
        "2.5,0.5,0",
    ]);
    assert!(String::from_utf8_lossy(&run.stderr).contains("is no folder"));
    assert!(!none.exists());
    // With --motion, --solution names the folder solve wrote, not a file.
    let run = coherad(&[
        "export",
        room,
        "--motion",
        m,
        "--solution",
        &format!("{o}/step_0000.json"),
        "--out",
        dir.join("g3").to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&run.stderr).contains("is a file"));
}

#[test]
fn a_shorter_run_into_the_same_folder_leaves_no_stale_steps() {
    let dir = tempfile::tempdir().unwrap();
    let sat = bench_scene("satellite.json");
    let motion = dir.path().join("m.json");
    let out = dir.path().join("steps");
    for (n, files_after) in [(3, 3), (2, 2)] {
        std::fs::write(&motion, turning(n)).unwrap();
        let run = coherad(&[
            "viewfactors",
            sat.to_str().unwrap(),
            "--resolution",
            "8x32",
            "--motion",
            motion.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(run.status.success(), "{err}");
        assert_eq!(files(&out).len(), files_after, "{:?}", files(&out));
        assert_eq!(err.contains("removed 1 step files"), n == 2, "{err}");
    }
}
