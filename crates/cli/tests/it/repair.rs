//! `--repair` on a mesh as files come: a closed torus with faces turned over and a
//! triangle folded onto its neighbour is refused naming the flag, loads with it and a
//! report, and then sees no backs.

use super::coherad;
use std::fmt::Write;

/// A closed torus of 40 x 20 quads cut into 1,600 triangles wound outward; every 9th
/// turned over if `flipped`; with `flap`, one more triangle folded onto triangle 100
/// (sharing its first edge, its apex inside it).
fn torus_obj(flipped: bool, flap: bool) -> String {
    let (nu, nv, big, small) = (40usize, 20usize, 1.0f64, 0.35f64);
    let mut text = String::new();
    let mut at = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (t, p) = (
                std::f64::consts::TAU * i as f64 / nu as f64,
                std::f64::consts::TAU * j as f64 / nv as f64,
            );
            let r = big + small * p.cos();
            at.push([r * t.cos(), small * p.sin(), r * t.sin()]);
        }
    }
    let id = |i: usize, j: usize| (i % nu) * nv + (j % nv);
    let mut tris = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, d, c]);
            tris.push([a, c, b]);
        }
    }
    // Outward: the signed volume positive.
    let volume: f64 = tris
        .iter()
        .map(|t| {
            let [p, q, r] = t.map(|k| at[k]);
            p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0])
                + p[2] * (q[0] * r[1] - q[1] * r[0])
        })
        .sum();
    assert!(volume > 0.0, "the torus is built outward");
    if flipped {
        tris.iter_mut().step_by(9).for_each(|t| t.swap(1, 2));
    }
    if flap {
        let [a, b, c] = tris[100].map(|k| at[k]);
        let inside = [0, 1, 2].map(|k| 0.2 * a[k] + 0.2 * b[k] + 0.6 * c[k]);
        at.push(inside);
        tris.push([tris[100][0], tris[100][1], at.len() - 1]);
    }
    for p in &at {
        writeln!(text, "v {:?} {:?} {:?}", p[0], p[1], p[2]).unwrap();
    }
    for t in &tris {
        writeln!(text, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
    }
    text
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_torus_with_faces_turned_over_and_a_fold_is_repaired() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("torus.obj");
    std::fs::write(&file, torus_obj(true, true)).unwrap();
    let f = file.to_str().unwrap();
    let common = ["--patch-size", "1", "--resolution", "24x96"];
    let some = ["--patches", "0-399"];
    // Without --repair: refused, the fold named with the flag that gets through.
    let out = coherad(&[&["formfactors", f][..], &common, &some].concat());
    assert!(!out.status.success());
    let e = stderr(&out);
    assert!(e.contains("overlap") && e.contains("--repair"), "{e}");
    // With it: a report of what changed, and no row sees a back.
    let out = coherad(&[&["formfactors", f, "--repair"][..], &common, &some].concat());
    let e = stderr(&out);
    assert!(out.status.success(), "{e}");
    assert!(
        e.contains(
            "repaired: 178 faces turned over, 1 face dropped as folded onto a coplanar neighbour"
        ),
        "{e}"
    );
    assert!(
        e.contains(r#""unnamed_object/face 1600" dropped: folded onto "unnamed_object/face 100""#),
        "{e}"
    );
    assert!(e.contains("1 piece, 1 closed"), "{e}");
    assert!(!e.contains("from behind"), "{e}");
}

#[test]
fn faces_turned_over_are_a_warning_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("torus.obj");
    std::fs::write(&file, torus_obj(true, false)).unwrap();
    let f = file.to_str().unwrap();
    let args = [
        "formfactors",
        f,
        "--patch-size",
        "1",
        "--resolution",
        "24x96",
        "--patches",
        "0-399",
    ];
    let out = coherad(&args);
    let e = stderr(&out);
    assert!(out.status.success(), "{e}");
    assert!(
        e.contains("--repair would mend this mesh: 178 faces turned over"),
        "{e}"
    );
    assert!(
        e.contains("from behind") && e.contains("oriented by --repair"),
        "{e}"
    );
    // A sound mesh gets neither.
    std::fs::write(&file, torus_obj(false, false)).unwrap();
    let out = coherad(&args);
    let e = stderr(&out);
    assert!(out.status.success(), "{e}");
    assert!(!e.contains("--repair") && !e.contains("from behind"), "{e}");
    // --weld is a setting of --repair.
    let out = coherad(&["patches", f, "--patch-size", "1", "--weld", "0.001"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--repair"), "{}", stderr(&out));
}
