//! A byte-level mutation fuzzer on stable Rust, for every scene-file parser: valid seed
//! files (built here) are mutated (bit flips, interesting bytes and words, deletions,
//! duplications, insertions of format tokens, truncation, splices of two inputs), fed
//! to the parser under `catch_unwind`, and whatever parses is validated as a scene,
//! triangulated and validated again; inputs that parse join the corpus (up to
//! [`MAX_CORPUS`], then replacing others at random), so mutations reach past the first
//! syntax check. No coverage
//! feedback: deterministic for a seed, so a finding replays.

use glam::{DVec3, Vec3};
use rad_geometry::file::{
    apply_material_text, gltf_from_bytes, gltf_motion_from_bytes, obj_from_bytes, ply_from_bytes,
    scene_desc_from_json, scene_desc_to_json, stl_from_bytes, vs3_from_text,
};
use rad_geometry::{scenes, triangulate, Scene, SceneDesc};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::time::{Duration, Instant};

/// Most inputs kept in a target's corpus.
pub const MAX_CORPUS: usize = 256;

/// Largest input a mutation makes (bytes).
pub const MAX_INPUT: usize = 1 << 16;

/// A small, fast, deterministic generator (SplitMix64).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// One parser under test: its seeds, its tokens, and the call.
pub struct Target {
    pub name: &'static str,
    /// The extension its files have (for saved findings).
    pub ext: &'static str,
    pub seeds: Vec<Vec<u8>>,
    /// Tokens worth inserting (keywords, numbers that break things).
    pub tokens: Vec<Vec<u8>>,
    /// Parses, validates and triangulates an input; must never panic.
    pub run: fn(&[u8]),
}

/// What a fuzzing run did.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    pub executions: u64,
    /// Inputs that parsed (and then went through validation).
    pub parsed: u64,
    pub corpus: usize,
    /// Each distinct panic message, with the first input that caused it.
    pub panics: Vec<(String, Vec<u8>)>,
    pub elapsed: Duration,
}

/// Mutates `input` (1 to 8 steps), splicing from `other` sometimes.
pub fn mutate(rng: &mut Rng, input: &[u8], other: &[u8], tokens: &[Vec<u8>]) -> Vec<u8> {
    const BYTES: [u8; 10] = [0, 1, 0x7f, 0x80, 0xff, b'\n', b' ', b'-', b'9', b'.'];
    const WORDS: [u32; 9] = [
        0,
        1,
        2,
        0x7fff_ffff,
        0x8000_0000,
        0xffff_ffff,
        0xffff,
        1 << 24,
        3,
    ];
    let mut out = input.to_vec();
    for _ in 0..1 + rng.below(8) {
        let len = out.len();
        match rng.below(10) {
            0 if len > 0 => {
                let i = rng.below(len);
                out[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                out[i] = BYTES[rng.below(BYTES.len())];
            }
            2 if len >= 4 => {
                let i = rng.below(len - 3);
                let w = WORDS[rng.below(WORDS.len())];
                let b = if rng.below(2) == 0 {
                    w.to_le_bytes()
                } else {
                    w.to_be_bytes()
                };
                out[i..i + 4].copy_from_slice(&b);
            }
            3 if len > 0 => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(64));
                out.drain(i..i + n);
            }
            4 if len > 0 && len < MAX_INPUT => {
                let i = rng.below(len);
                let n = 1 + rng.below((len - i).min(256));
                let piece = out[i..i + n].to_vec();
                let at = rng.below(len + 1);
                out.splice(at..at, piece);
            }
            5 | 6 if !tokens.is_empty() && len < MAX_INPUT => {
                let t = &tokens[rng.below(tokens.len())];
                let at = rng.below(len + 1);
                if rng.below(2) == 0 || at == len {
                    out.splice(at..at, t.iter().copied());
                } else {
                    let end = (at + t.len()).min(len);
                    out.splice(at..end, t.iter().copied());
                }
            }
            7 if len > 0 => out.truncate(rng.below(len)),
            8 if !other.is_empty() => {
                let cut = rng.below(out.len() + 1);
                let from = rng.below(other.len());
                out.truncate(cut);
                out.extend_from_slice(&other[from..]);
                out.truncate(MAX_INPUT);
            }
            _ => {
                let at = rng.below(len + 1);
                let b = (rng.next_u64() & 0xff) as u8;
                out.insert(at, b);
            }
        }
    }
    out
}

/// Fuzzes `target` until `iterations` executions or `budget` elapse, whichever first.
pub fn fuzz(target: &Target, seed: u64, iterations: u64, budget: Duration) -> Outcome {
    let mut rng = Rng::new(seed ^ fnv(target.name.as_bytes()));
    let mut corpus = target.seeds.clone();
    let mut outcome = Outcome::default();
    let start = Instant::now();
    // The seeds must run clean: they are valid files.
    for s in &target.seeds {
        check(target, s, &mut outcome);
    }
    while outcome.executions < iterations && start.elapsed() < budget {
        let a = &corpus[rng.below(corpus.len())];
        let b = &corpus[rng.below(corpus.len())];
        let input = mutate(&mut rng, a, b, &target.tokens);
        if check(target, &input, &mut outcome) {
            if corpus.len() < MAX_CORPUS {
                corpus.push(input);
            } else if rng.below(8) == 0 {
                // Keep the corpus moving: a parsing input replaces a random non-seed one.
                let k = target.seeds.len() + rng.below(MAX_CORPUS - target.seeds.len());
                corpus[k] = input;
            }
        }
    }
    outcome.corpus = corpus.len();
    outcome.elapsed = start.elapsed();
    outcome
}

/// Runs one input; records a panic; whether it parsed (took the path past parsing).
fn check(target: &Target, input: &[u8], outcome: &mut Outcome) -> bool {
    outcome.executions += 1;
    PARSED.with(|p| p.set(false));
    match catch_unwind(AssertUnwindSafe(|| (target.run)(input))) {
        Ok(()) => {}
        Err(e) => {
            let msg = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "a panic without a message".into());
            if !outcome.panics.iter().any(|(m, _)| *m == msg) {
                outcome.panics.push((msg, input.to_vec()));
            }
        }
    }
    let parsed = PARSED.with(|p| p.get());
    outcome.parsed += u64::from(parsed);
    parsed
}

thread_local! {
    static PARSED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// What every target does with a description that parsed: validate it, triangulate a
/// copy and validate that (each may refuse; none may panic).
fn validate(desc: SceneDesc) {
    PARSED.with(|p| p.set(true));
    if cells_bound(&desc) > MAX_FUZZ_CELLS {
        // A valid request for millions of patches takes seconds and gigabytes to build:
        // the limits' own tests cover it; the fuzzer moves on.
        return;
    }
    let _ = Scene::new(desc.clone());
    let mut split = desc;
    let _ = triangulate(&mut split);
    let _ = Scene::new(split);
}

/// Most patch cells a fuzzed scene is built with.
pub const MAX_FUZZ_CELLS: f64 = (1 << 16) as f64;

/// An upper bound of the cells `desc` asks for (a patch size is bounded by the polygon's
/// bounding box).
fn cells_bound(desc: &SceneDesc) -> f64 {
    desc.polygons
        .iter()
        .map(|p| match p.grid {
            rad_geometry::PatchGrid::Cells { nu, nv } => nu as f64 * nv as f64,
            rad_geometry::PatchGrid::Size(size) => {
                let (lo, hi) = p.vertices.iter().fold(
                    (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |(lo, hi), v| (lo.min(*v), hi.max(*v)),
                );
                let d = (hi - lo).length();
                let c = (2.0 * d / size + 2.0).powi(2);
                if c.is_nan() {
                    1.0
                } else {
                    c
                }
            }
        })
        .sum()
}

fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

const FUZZ_PATH: &str = "/nonexistent/fuzz";

fn tokens(words: &[&str]) -> Vec<Vec<u8>> {
    let common = [
        "nan",
        "NaN",
        "inf",
        "-inf",
        "1e39",
        "-1",
        "0",
        "-0",
        "1e-45",
        "4294967296",
        "18446744073709551616",
        "99999999999",
        "\n",
        " ",
        ",",
        ".",
        "e",
    ];
    common
        .iter()
        .chain(words)
        .map(|w| w.as_bytes().to_vec())
        .collect()
}

/// A few triangles of the blob (curved, irregular), and a concave quad-ish face.
fn seed_triangles() -> Vec<[Vec3; 3]> {
    let desc = scenes::blob_room();
    desc.polygons
        .iter()
        .filter(|p| p.vertices.len() == 3)
        .take(6)
        .map(|p| [0, 1, 2].map(|k| p.vertices[k].as_vec3()))
        .collect()
}

fn ply_seed(format: &str) -> Vec<u8> {
    let tris = seed_triangles();
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment seed\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        3 * tris.len(),
        tris.len() + 1
    )
    .into_bytes();
    let concave = [0u32, 1, 4, 2];
    if format == "ascii" {
        for v in tris.iter().flatten() {
            out.extend(format!("{} {} {}\n", v.x, v.y, v.z).bytes());
        }
        for k in 0..tris.len() as u32 {
            out.extend(format!("3 {} {} {}\n", 3 * k, 3 * k + 1, 3 * k + 2).bytes());
        }
        out.extend(
            format!(
                "4 {} {} {} {}\n",
                concave[0], concave[1], concave[2], concave[3]
            )
            .bytes(),
        );
    } else {
        for v in tris.iter().flatten() {
            for c in v.to_array() {
                out.extend(c.to_le_bytes());
            }
        }
        for k in 0..tris.len() as i32 {
            out.push(3);
            for i in [3 * k, 3 * k + 1, 3 * k + 2] {
                out.extend(i.to_le_bytes());
            }
        }
        out.push(4);
        for i in concave {
            out.extend((i as i32).to_le_bytes());
        }
    }
    out
}

fn stl_seed(ascii: bool) -> Vec<u8> {
    let tris = seed_triangles();
    let mut out = Vec::new();
    if ascii {
        out.extend(b"solid seed\n");
        for t in &tris {
            out.extend(b"facet normal 0 0 1\n outer loop\n");
            for v in t {
                out.extend(format!("  vertex {} {} {}\n", v.x, v.y, v.z).bytes());
            }
            out.extend(b" endloop\nendfacet\n");
        }
        out.extend(b"endsolid seed\n");
    } else {
        out.extend([b' '; 80]);
        out.extend((tris.len() as u32).to_le_bytes());
        for t in &tris {
            out.extend([0u8; 12]);
            for c in t.iter().flat_map(|v| v.to_array()) {
                out.extend(c.to_le_bytes());
            }
            out.extend([0u8; 2]);
        }
    }
    out
}

/// A glTF quad (two triangles, indexed), a node transform, a material, a camera; the
/// buffer as a data URI (`glb = false`) or the GLB's BIN chunk.
fn gltf_seed(glb: bool) -> Vec<u8> {
    let mut bin = Vec::new();
    for c in [0f32, 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.] {
        bin.extend(c.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    // An animation: times (60), node 2's rotations (68), node 0's translations (100).
    for c in [
        0f32, 1., 0., 0., 0., 1., 0.3826834, 0., 0., 0.9238795, 1., 0., 0., 1., 0.5, 0.,
    ] {
        bin.extend(c.to_le_bytes());
    }
    for c in [0f32, 0., 0.] {
        bin.extend(c.to_le_bytes());
    }
    let buffer = if glb {
        format!(r#"{{"byteLength": {}}}"#, bin.len())
    } else {
        const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut b64 = String::new();
        for c in bin.chunks(3) {
            let n = (u32::from(c[0]) << 16)
                | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
                | u32::from(*c.get(2).unwrap_or(&0));
            for k in 0..4 {
                b64.push(if k <= c.len() {
                    A[((n >> (18 - 6 * k)) & 63) as usize] as char
                } else {
                    '='
                });
            }
        }
        format!(
            r#"{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{b64}"}}"#,
            bin.len()
        )
    };
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
"nodes": [{{"mesh": 0, "translation": [1, 0, 0], "scale": [1, 1, -1], "children": [2]}}, {{"camera": 0, "translation": [0, 0, 3]}}, {{"mesh": 0, "rotation": [0, 0.7071068, 0, 0.7071068]}}],
"cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.8, "znear": 0.01}}}}],
"meshes": [{{"name": "quad", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}, {{"attributes": {{"POSITION": 0}}, "mode": 5}}]}}],
"materials": [{{"name": "m", "pbrMetallicRoughness": {{"baseColorFactor": [0.5, 0.5, 0.5, 1]}}, "emissiveFactor": [1, 1, 1], "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 4}}}}}}],
"buffers": [{buffer}],
"bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}, {{"buffer": 0, "byteOffset": 60, "byteLength": 8}}, {{"buffer": 0, "byteOffset": 68, "byteLength": 32}}, {{"buffer": 0, "byteOffset": 100, "byteLength": 24}}],
"accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}, {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}},
  {{"bufferView": 2, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]}}, {{"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC4"}}, {{"bufferView": 4, "componentType": 5126, "count": 2, "type": "VEC3"}}],
"animations": [{{"channels": [{{"sampler": 0, "target": {{"node": 2, "path": "rotation"}}}}, {{"sampler": 1, "target": {{"node": 0, "path": "translation"}}}}],
  "samplers": [{{"input": 2, "output": 3}}, {{"input": 2, "output": 4, "interpolation": "STEP"}}]}}]}}"#
    );
    if !glb {
        return json.into_bytes();
    }
    let mut j = json.into_bytes();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

const OBJ_SEED: &str = "o box\ng side\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nvn 0 0 1\nvt 0 0\n\
f 1 2 3 4\nf 5/1/1 8/1/1 7/1/1 6/1/1\nf 1 5 6 2\ng top\nusemtl none\nf 4 3 7 8\nf -8 -4 -1 -5\nf 2 6 7 3\nf 1 2 4 3 5\n";

const VS3_SEED: &str = "T Test: parallel plates with an obstruction\n\
C encl=0 list=0 eps=1.0e-4 maxU=8 minO=0 emit=1 row=0 col=0\n\
F 3\n\
! vertices\n\
V 1  0. 0. 0.\nV 2  1. 0. 0.\nV 3  1. 1. 0.\nV 4  0. 1. 0.\n\
V 5  0. 0. 1.\nV 6  1. 0. 1.\nV 7  1. 1. 1.\nV 8  0. 1. 1.\n\
V 9  0.2 0.2 0.5\nV 10 0.8 0.2 0.5\nV 11 0.8 0.8 0.5\nV 12 0.2 0.8 0.5\n\
S 1 1 2 3 4 0 0 0.9 bottom\n\
S 2 8 7 6 5 0 0 0.9 top\n\
O 3 9 12 11 10\n\
End of data\n";

const MATERIALS_SEED: &str = r#"{"materials": [{"name": "lamp", "reflectance": [0, 0, 0], "emission": [5, 5, 5]},
 {"name": "(default)", "reflectance": [0.7, 0.7, 0.7]}],
 "assign": [{"material": "lamp", "faces": [0, 2]},
 {"material": "lamp", "inside": {"min": [-1, -1, -1], "max": [2, 2, 2]}}]}"#;

/// Every scene-file parser: `json`, `obj`, `vs3`, `ply`, `stl`, `gltf`, `glb`,
/// `materials` (the side file, applied to the cube), `motion` (motion files, over the
/// satellite).
pub fn targets() -> Vec<Target> {
    let json_seed = |desc: SceneDesc| scene_desc_to_json(&desc, Some("seed")).into_bytes();
    vec![
        Target {
            name: "json",
            ext: "json",
            seeds: vec![
                json_seed(scenes::cube(2)),
                json_seed(scenes::cornell_box(200.0)),
                br#"{"patch_size": 0.5, "materials": [{"name": "w", "reflectance": [0.5, 0.5, 0.5]}], "vertices": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "polygons": [{"material": "w", "indices": [0, 1, 2, 3], "group": "g"}, {"material": "w", "vertices": [[0,0,1],[0,1,1],[1,1,1]], "patches": [3, 2], "obstruction": true}], "camera": {"position": [0.5, 0.5, 3], "look_at": [0.5, 0.5, 0], "up": [0, 1, 0], "fov_y_deg": 40}}"#.to_vec(),
            ],
            tokens: tokens(&["{", "}", "[", "]", "\"", ":", "\"patches\"", "\"indices\"", "\"vertices\"", "\"patch_size\"", "null", "true", "[0, 0, 0]", "[1e30, 1, 1]"]),
            run: |b| {
                if let Ok(text) = std::str::from_utf8(b) {
                    if let Ok(desc) = scene_desc_from_json(text, Some(0.5)) {
                        validate(desc);
                    }
                }
            },
        },
        Target {
            name: "obj",
            ext: "obj",
            seeds: vec![OBJ_SEED.as_bytes().to_vec()],
            tokens: tokens(&["v ", "f ", "vt ", "vn ", "o ", "g ", "usemtl ", "mtllib x.mtl", "/", "//", "-1", "-9"]),
            run: |b| {
                if let Ok(desc) = obj_from_bytes(Path::new(FUZZ_PATH), b, 0.3, None) {
                    validate(desc);
                }
            },
        },
        Target {
            name: "vs3",
            ext: "vs3",
            seeds: vec![VS3_SEED.as_bytes().to_vec()],
            tokens: tokens(&["V ", "S ", "O ", "C ", "F ", "T ", "M ", "End of data", "encl=1", "emit=1", "!", "maxU=", "="]),
            run: |b| {
                if let Ok(text) = std::str::from_utf8(b) {
                    if let Ok((desc, _)) = vs3_from_text(text, None) {
                        validate(desc);
                    }
                }
            },
        },
        Target {
            name: "ply",
            ext: "ply",
            seeds: vec![ply_seed("ascii"), ply_seed("binary_little_endian"), ply_seed("binary_big_endian")],
            tokens: tokens(&["element ", "property ", "list ", "uchar ", "int ", "float ", "double ", "face ", "vertex ", "end_header\n", "vertex_indices", "comment ", "format "]),
            run: |b| {
                if let Ok(desc) = ply_from_bytes(Path::new(FUZZ_PATH), b, 0.3, None) {
                    validate(desc);
                }
            },
        },
        Target {
            name: "stl",
            ext: "stl",
            seeds: vec![stl_seed(true), stl_seed(false)],
            tokens: tokens(&["solid ", "facet normal ", "outer loop", "vertex ", "endloop", "endfacet", "endsolid"]),
            run: |b| {
                if let Ok(desc) = stl_from_bytes(Path::new(FUZZ_PATH), b, 0.3, None) {
                    validate(desc);
                }
            },
        },
        Target {
            name: "gltf",
            ext: "gltf",
            seeds: vec![gltf_seed(false)],
            tokens: tokens(&["{", "}", "[", "]", "\"", ":", "\"mode\": 6", "\"children\": [0]", "\"sparse\": {}", "\"byteStride\": 4", "\"componentType\": 5125", "\"uri\": \"x.bin\"", "\"matrix\": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,0]", "\"interpolation\": \"CUBICSPLINE\"", "\"path\": \"scale\"", "\"path\": \"weights\"", "\"normalized\": true, \"componentType\": 5122"]),
            run: |b| {
                let mut notes = Vec::new();
                if let Ok(desc) = gltf_from_bytes(Path::new(FUZZ_PATH), b, 0.3, None, &mut notes) {
                    validate(desc);
                }
                // (Its animations as a motion: parsed, never a panic.)
                let _ = gltf_motion_from_bytes(Path::new(FUZZ_PATH), b);
            },
        },
        Target {
            name: "glb",
            ext: "glb",
            seeds: vec![gltf_seed(true)],
            tokens: tokens(&["glTF", "JSON", "BIN\0", "\"byteOffset\": 1", "\"count\": 1000000"]),
            run: |b| {
                let mut notes = Vec::new();
                if let Ok(desc) = gltf_from_bytes(Path::new(FUZZ_PATH), b, 0.3, None, &mut notes) {
                    validate(desc);
                }
                // (Its animations as a motion: parsed, never a panic.)
                let _ = gltf_motion_from_bytes(Path::new(FUZZ_PATH), b);
            },
        },
        Target {
            name: "materials",
            ext: "json",
            seeds: vec![MATERIALS_SEED.as_bytes().to_vec()],
            tokens: tokens(&["{", "}", "[", "]", "\"", ":", "\"faces\": [0, 99]", "\"inside\"", "\"assign\"", "\"materials\"", "\"name\": \"lamp\""]),
            run: |b| {
                if let Ok(text) = std::str::from_utf8(b) {
                    let mut desc = scenes::cube(2);
                    if apply_material_text(&mut desc, text, Path::new(FUZZ_PATH)).is_ok() {
                        validate(desc);
                    }
                }
            },
        },
        motion_target(),
    ]
}

/// Motion files, parsed, checked against the satellite and each of their first steps'
/// scenes made (a step may be refused, never panic).
fn motion_target() -> Target {
    Target {
        name: "motion",
        ext: "json",
        seeds: vec![
            scenes::satellite_motion(3)
                .to_json(Some("seed"))
                .into_bytes(),
            MOTION_SEED.as_bytes().to_vec(),
            KEYFRAME_SEED.as_bytes().to_vec(),
        ],
        tokens: tokens(&[
            "{",
            "}",
            "[",
            "]",
            "\"",
            ":",
            "\"rotate\"",
            "\"matrix\"",
            "\"about\"",
            "\"translate\"",
            "\"degrees\": 1e308",
            "\"axis\": [0, 0, 0]",
            "\"bus\"",
            "\"array +x\"",
            "\"steps\": []",
            "\"keyframes\"",
            "\"times\"",
            "\"time\": 1e308",
            "\"times\": [1e308, -1e308, 0]",
        ]),
        run: |b| {
            // Parsed, checked against the satellite, and each step's scene made (a
            // step may be refused, never panic).
            if let Ok(text) = std::str::from_utf8(b) {
                if let Ok(motion) = rad_geometry::Motion::parse(text, Path::new(FUZZ_PATH)) {
                    PARSED.with(|p| p.set(true));
                    let desc = scenes::satellite();
                    if motion.check(&desc).is_ok() {
                        if let Ok(cut) = Scene::new(desc.clone()) {
                            let unit = motion.unit(&desc);
                            for k in 0..motion.steps.len().min(4) {
                                let _ = motion.step_scene(&desc, &cut, k, unit);
                            }
                        }
                    }
                }
            }
        },
    }
}

const KEYFRAME_SEED: &str = r#"{"keyframes": [{"time": 0, "groups": {"array +x": {"rotate": {"axis": [1, 0, 0], "degrees": 0}, "about": [0, 0, 0]}}},
 {"time": 2, "groups": {"array +x": {"rotate": {"axis": [1, 0, 0], "degrees": 170}}, "antenna": {"translate": [0, 0, 0.2]}}}], "times": [-1, 0, 0.5, 1, 2, 3]}"#;

const MOTION_SEED: &str = r#"{"steps": [{"name": "a", "groups": {"array +x": {"rotate": {"axis": [1, 0, 0], "degrees": 30}, "about": [0, 0, 0]}}},
 {"groups": {"array -x": {"matrix": [[1, 0, 0], [0, 0, -1], [0, 1, 0]], "translate": [0, 0, 0.1]}, "antenna": {"translate": [0, 0, 0.2]}}}]}"#;
