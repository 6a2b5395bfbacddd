//! The README's first screen, followed on a mesh of one's own: its material side file and
//! its commands (solve, render, export, view factors), run on an OBJ made here, must
//! give a solution, an image, a glTF and a view-factor table.

use std::path::Path;

/// The README's text between the heading `## Run it on your own mesh` and the next
/// `## `.
fn own_mesh_section() -> String {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md"))
            .unwrap();
    let start = readme
        .find("## Run it on your own mesh")
        .expect("the README's section on one's own mesh");
    let section = &readme[start..];
    let end = section[3..].find("\n## ").map_or(section.len(), |k| k + 3);
    section[..end].to_string()
}

/// The fenced blocks of `lang` in `text`.
fn blocks(text: &str, lang: &str) -> Vec<String> {
    let fence = format!("```{lang}\n");
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find(&fence) {
        let body = &rest[at + fence.len()..];
        let end = body.find("```").expect("a closed block");
        out.push(body[..end].to_string());
        rest = &body[end..];
    }
    out
}

/// A closed 4 × 3 × 4 room (faces inward), a box on its floor, and a lamp panel just
/// under the ceiling facing down, where the README's lamp rule looks for it.
fn room_obj() -> String {
    let mut v: Vec<[f64; 3]> = Vec::new();
    let mut f: Vec<[usize; 4]> = Vec::new();
    let mut quad = |v: &mut Vec<[f64; 3]>, q: [[f64; 3]; 4]| {
        let k = v.len();
        v.extend(q);
        f.push([k + 1, k + 2, k + 3, k + 4]);
    };
    let (x0, x1, y1, z0, z1) = (-2.0, 2.0, 3.0, -2.0, 2.0);
    // Room, counter-clockwise seen from inside.
    quad(
        &mut v,
        [[x0, 0.0, z0], [x0, 0.0, z1], [x1, 0.0, z1], [x1, 0.0, z0]],
    );
    quad(
        &mut v,
        [[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]],
    );
    quad(
        &mut v,
        [[x0, 0.0, z0], [x1, 0.0, z0], [x1, y1, z0], [x0, y1, z0]],
    );
    quad(
        &mut v,
        [[x0, 0.0, z1], [x0, y1, z1], [x1, y1, z1], [x1, 0.0, z1]],
    );
    quad(
        &mut v,
        [[x0, 0.0, z0], [x0, y1, z0], [x0, y1, z1], [x0, 0.0, z1]],
    );
    quad(
        &mut v,
        [[x1, 0.0, z0], [x1, 0.0, z1], [x1, y1, z1], [x1, y1, z0]],
    );
    // A lamp panel 5 cm under the ceiling, facing down.
    let (l0, l1, ly) = (-0.4, 0.4, 2.95);
    quad(
        &mut v,
        [[l0, ly, l0], [l1, ly, l0], [l1, ly, l1], [l0, ly, l1]],
    );
    // A box on the floor: its top and four sides, facing out.
    let (h, bx, bz, w) = (1.3, 0.5, -1.0, 0.8);
    let (a, b) = ([bx, 0.0, bz], [bx + w, 0.0, bz]);
    let (c, d) = ([bx + w, 0.0, bz + w], [bx, 0.0, bz + w]);
    let up = |p: [f64; 3]| [p[0], h, p[2]];
    quad(&mut v, [up(a), up(d), up(c), up(b)]);
    for (p, q) in [(a, b), (b, c), (c, d), (d, a)] {
        quad(&mut v, [q, p, up(p), up(q)]);
    }
    let mut s = String::from("# a room of one's own\n");
    for p in v {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for q in f {
        s += &format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]);
    }
    s
}

#[test]
fn the_readme_commands_work_on_a_mesh_of_ones_own() {
    let section = own_mesh_section();
    let json = blocks(&section, "json");
    let sh = blocks(&section, "sh");
    assert_eq!((json.len(), sh.len()), (1, 1), "{section}");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.obj"), room_obj()).unwrap();
    std::fs::write(dir.path().join("room.obj"), room_obj()).unwrap();
    std::fs::write(dir.path().join("lights.json"), &json[0]).unwrap();
    // Each command of the block, continuation lines joined, run in the folder, at a
    // coarser resolution than the default (the same commands otherwise).
    let commands = sh[0].replace("\\\n", " ");
    let mut ran = Vec::new();
    for line in commands.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let words: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(words[0], "coherad", "{line}");
        let mut args: Vec<String> = words[1..].iter().map(|w| w.to_string()).collect();
        args.extend(["--resolution".to_string(), "24x96".to_string()]);
        if matches!(words[1], "render" | "export") {
            args.truncate(args.len() - 2); // (they take no resolution)
        }
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_coherad"))
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{line}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        ran.push(words[1].to_string());
    }
    assert_eq!(ran, ["solve", "render", "export", "viewfactors"]);
    let solution: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("mesh.solution.json")).unwrap(),
    )
    .unwrap();
    let b = solution["radiosity"].as_array().unwrap();
    let lit = b.iter().filter(|x| x[0].as_f64().unwrap() > 0.0).count();
    assert!(lit > b.len() / 2, "{lit} of {} patches lit", b.len());
    for file in ["mesh.exr", "mesh.png", "mesh.glb", "vf.csv"] {
        let len = std::fs::metadata(dir.path().join(file)).map_or(0, |m| m.len());
        assert!(len > 0, "{file} was not written");
    }
    let glb = std::fs::read(dir.path().join("mesh.glb")).unwrap();
    assert_eq!(&glb[..4], b"glTF");
    let csv = std::fs::read_to_string(dir.path().join("vf.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 12, "a header and 12 faces:\n{csv}");
}
