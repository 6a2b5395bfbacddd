//! A glTF file's node animations as a motion: steps at the keyframe times, each mesh's
//! group moved with its node (and its node's children), what stays left alone; what is
//! not rigid or not clear refused by place.

use crate::meshes::{base64, write};
use glam::DVec3;
use rad_geometry::file::{load, read_motion, LoadConfig};
use rad_geometry::Scene;

/// A floor (mesh "floor", node 0), a lid (mesh "lid", node 1, at y = 1 facing down) and
/// a handle on it (mesh "handle", node 2, a child of node 1); node 1 turns about x from
/// 0° to 90° at times 0, 0.5 and 1 (`rotations`: the three quaternions as JSON text),
/// `extra` more channels (JSON, after the first, samplers 1 and on of `samplers`).
fn hinged(rotations: [[f32; 4]; 3], extra_channels: &str, extra_samplers: &str) -> String {
    let mut bin = Vec::new();
    let f = |bin: &mut Vec<u8>, v: &[f32]| v.iter().for_each(|c| bin.extend(c.to_le_bytes()));
    // 0: floor positions (48 bytes), 48: lid (48), 96: handle (48), 144: indices (12),
    // 156: times (12), 168: rotations (48), 216: scales (36).
    f(
        &mut bin,
        &[-1., 0., -1., -1., 0., 1., 1., 0., 1., 1., 0., -1.],
    );
    f(&mut bin, &[0., 1., 0., 1., 1., 0., 1., 1., 1., 0., 1., 1.]);
    f(
        &mut bin,
        &[0.2, 1.2, 0.4, 0.2, 1.2, 0.6, 0.8, 1.2, 0.6, 0.8, 1.2, 0.4],
    );
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    f(&mut bin, &[0.0, 0.5, 1.0]);
    for q in rotations {
        f(&mut bin, &q);
    }
    f(&mut bin, &[1., 1., 1., 2., 2., 2., 1., 1., 1.]);
    let view = |offset: usize, len: usize| {
        format!(r#"{{"buffer": 0, "byteOffset": {offset}, "byteLength": {len}}}"#)
    };
    let views = [
        view(0, 48),
        view(48, 48),
        view(96, 48),
        view(144, 12),
        view(156, 12),
        view(168, 48),
        view(216, 36),
    ]
    .join(", ");
    let mesh = |name: &str, acc: usize| {
        format!(
            r#"{{"name": "{name}", "primitives": [{{"attributes": {{"POSITION": {acc}}}, "indices": 3}}]}}"#
        )
    };
    let pos = |view: usize| {
        format!(
            r#"{{"bufferView": {view}, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 1.2, 1]}}"#
        )
    };
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0,
  "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"mesh": 1, "children": [2]}}, {{"mesh": 2}}],
  "meshes": [{}, {}, {}],
  "animations": [{{"channels": [{{"sampler": 0, "target": {{"node": 1, "path": "rotation"}}}}{extra_channels}],
                   "samplers": [{{"input": 4, "output": 5}}{extra_samplers}]}}],
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{b64}"}}],
  "bufferViews": [{views}],
  "accessors": [{}, {}, {},
                {{"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}},
                {{"bufferView": 4, "componentType": 5126, "count": 3, "type": "SCALAR", "min": [0], "max": [1]}},
                {{"bufferView": 5, "componentType": 5126, "count": 3, "type": "VEC4"}},
                {{"bufferView": 6, "componentType": 5126, "count": 3, "type": "VEC3"}}]
}}"#,
        mesh("floor", 0),
        mesh("lid", 1),
        mesh("handle", 2),
        pos(0),
        pos(1),
        pos(2),
        len = bin.len(),
        b64 = base64(&bin),
    )
}

fn turn_x(degrees: f32) -> [f32; 4] {
    let h = degrees.to_radians() / 2.0;
    [h.sin(), 0.0, 0.0, h.cos()]
}

#[test]
fn a_gltf_animation_moves_its_meshes_with_their_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let text = hinged([turn_x(0.0), turn_x(45.0), turn_x(90.0)], "", "");
    let path = write(dir.path(), "hinge.gltf", text.as_bytes());
    let motion = read_motion(&path).unwrap();
    let names: Vec<&str> = motion.steps.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["t = 0", "t = 0.5", "t = 1"]);
    // At rest at t = 0: nothing moves; the floor never does.
    assert!(
        motion.steps[0].poses.is_empty(),
        "{:?}",
        motion.steps[0].poses
    );
    for (k, degrees) in [(1, 45f64), (2, 90.0)] {
        let poses = &motion.steps[k].poses;
        assert_eq!(poses.keys().collect::<Vec<_>>(), ["handle", "lid"]);
        // The handle turns with the lid, about the lid's node origin.
        assert_eq!(poses["handle"], poses["lid"]);
        let p = poses["lid"].apply(DVec3::new(0.0, 1.0, 0.0));
        let (s, c) = degrees.to_radians().sin_cos();
        assert!((p - DVec3::new(0.0, c, s)).length() < 1e-6, "{k}: {p}");
    }
    // One mesh placed by two nodes that move alike (the lid's node and a child of it):
    // taken, whatever the rounding of their poses.
    let twice = text.replace(
        r#"{"mesh": 2}]"#,
        r#"{"mesh": 1, "translation": [0.3, 0.7, -0.2], "rotation": [0.1, 0.2, 0.3, 0.927362]}]"#,
    );
    assert_ne!(twice, text);
    let path2 = write(dir.path(), "twice.gltf", twice.as_bytes());
    let m2 = read_motion(&path2).unwrap();
    let p = m2.steps[1].poses["lid"].apply(DVec3::new(0.0, 1.0, 0.0));
    let half = std::f64::consts::FRAC_1_SQRT_2;
    assert!((p - DVec3::new(0.0, half, half)).length() < 1e-6, "{p}");
    // The scene the file loads has these groups, and each step makes a scene.
    let config = LoadConfig {
        patch_size: Some(0.5),
        ..LoadConfig::default()
    };
    let desc = load(&path, &config).unwrap().desc;
    motion.check(&desc).unwrap();
    let cut = Scene::new(desc.clone()).unwrap();
    let unit = motion.unit(&desc);
    for k in 0..motion.steps.len() {
        motion.step_scene(&desc, &cut, k, unit).unwrap();
    }
}

#[test]
fn what_a_gltf_animation_cannot_be_is_refused_by_place() {
    let dir = tempfile::tempdir().unwrap();
    let rot = [turn_x(0.0), turn_x(45.0), turn_x(90.0)];
    let scale_channel = r#", {"sampler": 1, "target": {"node": 1, "path": "scale"}}"#;
    let scale_sampler = r#", {"input": 4, "output": 6}"#;
    for (text, says) in [
        (hinged(rot, scale_channel, scale_sampler), "scaled or sheared"),
        (
            hinged(rot, r#", {"sampler": 1, "target": {"node": 1, "path": "rotation"}}"#, r#", {"input": 4, "output": 5}"#),
            "a second channel on the node's Rotation",
        ),
        (
            hinged(rot, "", "").replace(r#""nodes": [{"mesh": 0}, "#, r#""nodes": [{"mesh": 1}, "#),
            "mesh \"lid\" is placed by node",
        ),
        (
            hinged(rot, "", "").replace(r#""count": 3, "type": "VEC4""#, r#""count": 2, "type": "VEC4""#),
            "2 output values for 3 times",
        ),
        (
            hinged(rot, "", "").replace(r#""count": 3, "type": "VEC4""#, r#""count": 30, "type": "VEC4""#),
            "do not fit its bufferView",
        ),
        // (What the gltf crate would unwrap blindly: found by the fuzzer.)
        (
            hinged(rot, "", "").replace(r#""path": "rotation""#, r#""path": "rotatoin""#),
            "its target's path is not",
        ),
        (
            hinged(rot, "", "").replace(r#""target": {"node": 1,"#, r#""target": {"node": 90,"#),
            "node 90 of 3",
        ),
        (
            hinged([turn_x(0.0), [0.0; 4], turn_x(90.0)], "", ""),
            "a rotation of zero length",
        ),
        (
            hinged(rot, "", "").replace(r#""animations": [{"channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}}],
                   "samplers": [{"input": 4, "output": 5}]}],"#, ""),
            "has no node animation",
        ),
    ] {
        let path = write(dir.path(), "bad.gltf", text.as_bytes());
        let e = read_motion(&path).unwrap_err().to_string();
        assert!(e.contains("bad.gltf") && e.contains(says), "{says}: {e}");
    }
}
