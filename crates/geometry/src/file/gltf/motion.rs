//! A glTF file's node animations as a [`Motion`] of the groups its scene loads with
//! (each mesh's name: [`super::gltf_from_bytes`]): a step at every keyframe time of its
//! channels, each group's pose the move of its node's world transform from the scene
//! as written (the nodes' own transforms) to the one the animation gives at that time.

use super::{check_accessor, err, first_visit, load_buffers, parse_document, Want};
use crate::error::Error;
use crate::motion::{Motion, MotionStep, Rigid, MAX_STEPS, RIGID_TOLERANCE};
use glam::{DMat3, DMat4, DQuat, DVec3};
use gltf::animation::{Interpolation, Property};
use std::collections::BTreeMap;
use std::path::Path;

/// A node's local transform as translation, rotation and scale (f64, from the file's
/// f32), or a matrix (which no channel may animate).
#[derive(Clone, Copy, PartialEq)]
enum Local {
    Trs(DVec3, DQuat, DVec3),
    Matrix(DMat4),
}

impl Local {
    fn matrix(&self) -> DMat4 {
        match *self {
            Local::Trs(t, r, s) => DMat4::from_scale_rotation_translation(s, r.normalize(), t),
            Local::Matrix(m) => m,
        }
    }
}

/// One animated property of one node: times, and values (three a time for cubic
/// splines: in-tangent, value, out-tangent).
struct Channel {
    node: usize,
    property: Property,
    interpolation: Interpolation,
    times: Vec<f64>,
    values: Vec<[f64; 4]>,
}

impl Channel {
    /// The property's value at `t` (held before the first time and after the last; a
    /// keyframe's own value at its time).
    fn at(&self, t: f64) -> [f64; 4] {
        let n = self.times.len();
        let value = |k: usize| match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        };
        let after = self.times.partition_point(|&x| x <= t);
        if after == 0 {
            return value(0);
        }
        if after == n || self.times[after - 1] == t {
            return value(after - 1);
        }
        let (k, t0, t1) = (after - 1, self.times[after - 1], self.times[after]);
        let s = (t - t0) / (t1 - t0);
        let rotation = self.property == Property::Rotation;
        match self.interpolation {
            Interpolation::Step => value(k),
            Interpolation::Linear if rotation => {
                // (slerp takes unit quaternions; normalised integers are not quite.)
                let (a, b) = (quat(value(k)).normalize(), quat(value(k + 1)).normalize());
                let b = if a.dot(b) < 0.0 { -b } else { b };
                a.slerp(b, s).normalize().to_array()
            }
            Interpolation::Linear => {
                let (a, b) = (value(k), value(k + 1));
                std::array::from_fn(|i| a[i] + (b[i] - a[i]) * s)
            }
            Interpolation::CubicSpline => {
                // glTF's Hermite spline: tangents scaled by the keyframes' interval.
                let d = t1 - t0;
                let (p0, m0) = (self.values[3 * k + 1], self.values[3 * k + 2]);
                let (p1, m1) = (self.values[3 * k + 4], self.values[3 * k + 3]);
                let (s2, s3) = (s * s, s * s * s);
                let h = [
                    2.0 * s3 - 3.0 * s2 + 1.0,
                    (s3 - 2.0 * s2 + s) * d,
                    -2.0 * s3 + 3.0 * s2,
                    (s3 - s2) * d,
                ];
                let v: [f64; 4] = std::array::from_fn(|i| {
                    h[0] * p0[i] + h[1] * m0[i] + h[2] * p1[i] + h[3] * m1[i]
                });
                if rotation {
                    quat(v).normalize().to_array()
                } else {
                    v
                }
            }
        }
    }
}

fn quat(v: [f64; 4]) -> DQuat {
    DQuat::from_xyzw(v[0], v[1], v[2], v[3])
}

/// The motion of `path`'s glTF node animations: a step at every distinct keyframe time
/// of every channel (named `t = TIME`), each mesh node's group (its mesh's name) moved
/// from where the file places it to where the animation does at that time; a group
/// whose node (and every node above it) is where the file places it is not moved.
/// Refused: no animation; a scale that changes, morph-target weights (not rigid); two
/// channels on one property of a node; a channel on a node given by a matrix; a mesh
/// placed by two nodes that the animation moves differently; a malformed accessor.
pub fn gltf_motion(path: &Path) -> Result<Motion, Error> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    gltf_motion_from_bytes(path, &bytes)
}

/// [`gltf_motion`] of a file in memory (external buffers read beside `path`, which
/// errors name).
pub fn gltf_motion_from_bytes(path: &Path, bytes: &[u8]) -> Result<Motion, Error> {
    let gltf = parse_document(path, bytes)?;
    check_animations(path, gltf.document.as_json())?;
    let buffers = load_buffers(path, &gltf)?;
    let doc = &gltf.document;
    let fail = |message: String| Error::Motion {
        path: path.to_path_buf(),
        message,
    };
    let rest: Vec<Local> = doc.nodes().map(local_of).collect();
    let channels = read_channels(path, doc, &buffers, &rest)?;
    if channels.is_empty() {
        return Err(fail(
            "has no node animation (translation or rotation channels) to make steps of".into(),
        ));
    }
    let mut times: Vec<f64> = channels
        .iter()
        .flat_map(|c| c.times.iter().copied())
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    if times.len() > MAX_STEPS {
        return Err(fail(format!(
            "its animations have {} distinct keyframe times, over the limit of {MAX_STEPS} steps",
            times.len()
        )));
    }
    // The scene's mesh nodes and their ancestors (the loader's walk: the default scene).
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| err(path, "has no scene"))?;
    let mut parent = vec![None; doc.nodes().len()];
    let mut order = Vec::new();
    let mut visited = vec![false; doc.nodes().len()];
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    while let Some(node) = stack.pop() {
        first_visit(path, &mut visited, node.index())?;
        order.push(node.index());
        for c in node.children() {
            parent[c.index()] = Some(node.index());
            stack.push(c);
        }
    }
    // Each node's group, if it places a mesh (the loader's name for it).
    let groups: Vec<Option<String>> = doc
        .nodes()
        .map(|node| {
            node.mesh().map(|mesh| {
                mesh.name()
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("mesh {}", mesh.index()))
            })
        })
        .collect();
    let mut steps = Vec::with_capacity(times.len());
    for &t in &times {
        let mut local = rest.clone();
        for c in &channels {
            let v = c.at(t);
            if let Local::Trs(tr, r, s) = &mut local[c.node] {
                match c.property {
                    Property::Translation => *tr = DVec3::new(v[0], v[1], v[2]),
                    Property::Rotation => *r = quat(v),
                    Property::Scale => *s = DVec3::new(v[0], v[1], v[2]),
                    Property::MorphTargetWeights => {}
                }
            }
        }
        let poses = group_poses(&groups, &order, &parent, &rest, &local)
            .map_err(|why| fail(format!("at t = {t}: {why}")))?;
        steps.push(MotionStep {
            name: format!("t = {t}"),
            poses,
        });
    }
    Ok(Motion {
        path: path.to_path_buf(),
        steps,
    })
}

/// Checks what the `gltf` crate's animation accessors unwrap (its validation lets them
/// through): every channel's sampler, node and path, every sampler's accessors and
/// interpolation.
fn check_animations(path: &Path, json: &gltf::json::Root) -> Result<(), Error> {
    use gltf::json::validation::Checked;
    for (a, anim) in json.animations.iter().enumerate() {
        for (c, ch) in anim.channels.iter().enumerate() {
            let place = format!("animation {a} channel {c}");
            if ch.sampler.value() >= anim.samplers.len() {
                return Err(err(
                    path,
                    format!(
                        "{place}: sampler {} of {}",
                        ch.sampler.value(),
                        anim.samplers.len()
                    ),
                ));
            }
            if ch.target.node.value() >= json.nodes.len() {
                return Err(err(
                    path,
                    format!(
                        "{place}: node {} of {}",
                        ch.target.node.value(),
                        json.nodes.len()
                    ),
                ));
            }
            if !matches!(ch.target.path, Checked::Valid(_)) {
                return Err(err(
                    path,
                    format!(
                        "{place}: its target's path is not translation, rotation, scale or weights"
                    ),
                ));
            }
        }
        for (k, sampler) in anim.samplers.iter().enumerate() {
            let place = format!("animation {a} sampler {k}");
            for acc in [sampler.input.value(), sampler.output.value()] {
                if acc >= json.accessors.len() {
                    return Err(err(
                        path,
                        format!("{place}: accessor {acc} of {}", json.accessors.len()),
                    ));
                }
            }
            if !matches!(sampler.interpolation, Checked::Valid(_)) {
                return Err(err(
                    path,
                    format!("{place}: interpolation is not LINEAR, STEP or CUBICSPLINE"),
                ));
            }
        }
    }
    Ok(())
}

/// A node's transform as the file gives it.
fn local_of(node: gltf::Node) -> Local {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            Local::Matrix(DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from))))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => Local::Trs(
            DVec3::from(translation.map(f64::from)),
            quat(rotation.map(f64::from)),
            DVec3::from(scale.map(f64::from)),
        ),
    }
}

/// Every translation, rotation and scale channel of every animation, checked.
fn read_channels(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    rest: &[Local],
) -> Result<Vec<Channel>, Error> {
    let mut out: Vec<Channel> = Vec::new();
    for anim in doc.animations() {
        for ch in anim.channels() {
            let node = ch.target().node().index();
            let property = ch.target().property();
            let place = format!("animation {} channel {}", anim.index(), ch.index());
            let fail = |m: String| Err(err(path, format!("{place} (node {node}): {m}")));
            if property == Property::MorphTargetWeights {
                return fail(
                    "animates morph-target weights, which bend a mesh: not a rigid motion".into(),
                );
            }
            if matches!(rest[node], Local::Matrix(_)) {
                return fail(
                    "animates a node given by a matrix (glTF animates TRS nodes only)".into(),
                );
            }
            if out.iter().any(|c| c.node == node && c.property == property) {
                return fail(format!("a second channel on the node's {property:?}"));
            }
            let sampler = ch.sampler();
            let interpolation = sampler.interpolation();
            let (input, output) = (sampler.input(), sampler.output());
            check_accessor(path, &input, buffers, &place, "input", Want::Times)?;
            let want = if property == Property::Rotation {
                Want::Rotations
            } else {
                Want::Positions
            };
            check_accessor(path, &output, buffers, &place, "output", want)?;
            let per = if interpolation == Interpolation::CubicSpline {
                3
            } else {
                1
            };
            if output.count() != per * input.count() {
                return fail(format!(
                    "{} output values for {} times ({interpolation:?} takes {per} a time)",
                    output.count(),
                    input.count()
                ));
            }
            let reader = ch.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let times: Vec<f64> = reader
                .read_inputs()
                .map(|i| i.map(f64::from).collect())
                .unwrap_or_default();
            if let Some(k) = (0..times.len())
                .find(|&k| !times[k].is_finite() || (k > 0 && times[k] <= times[k - 1]))
            {
                return fail(format!(
                    "time {k} ({}) is not finite or not after the one before",
                    times[k]
                ));
            }
            let values: Vec<[f64; 4]> = match reader.read_outputs() {
                Some(gltf::animation::util::ReadOutputs::Translations(v))
                | Some(gltf::animation::util::ReadOutputs::Scales(v)) => v
                    .map(|x| [x[0].into(), x[1].into(), x[2].into(), 0.0])
                    .collect(),
                Some(gltf::animation::util::ReadOutputs::Rotations(r)) => {
                    r.into_f32().map(|x| x.map(f64::from)).collect()
                }
                _ => Vec::new(),
            };
            if values.len() != output.count() || values.iter().flatten().any(|v| !v.is_finite()) {
                return fail("its output values are missing or not finite".into());
            }
            if property == Property::Rotation
                && values
                    .iter()
                    .skip(usize::from(per == 3))
                    .step_by(per)
                    .any(|q| quat(*q).length() < 1e-6)
            {
                return fail("a rotation of zero length".into());
            }
            out.push(Channel {
                node,
                property,
                interpolation,
                times,
                values,
            });
        }
    }
    Ok(out)
}

/// Each mesh group's pose (`W(t) · W_rest⁻¹` of its node's world transforms), for the
/// groups whose node or an ancestor is not where the file places it.
fn group_poses(
    groups: &[Option<String>],
    order: &[usize],
    parent: &[Option<usize>],
    rest: &[Local],
    local: &[Local],
) -> Result<BTreeMap<String, Rigid>, String> {
    let n = rest.len();
    let (mut w_rest, mut w_now) = (vec![DMat4::IDENTITY; n], vec![DMat4::IDENTITY; n]);
    let mut moved = vec![false; n];
    for &i in order {
        let (pr, pn, pm) = match parent[i] {
            Some(p) => (w_rest[p], w_now[p], moved[p]),
            None => (DMat4::IDENTITY, DMat4::IDENTITY, false),
        };
        w_rest[i] = pr * rest[i].matrix();
        moved[i] = pm || local[i] != rest[i];
        w_now[i] = if moved[i] {
            pn * local[i].matrix()
        } else {
            w_rest[i]
        };
    }
    let mut poses: BTreeMap<String, (Rigid, usize)> = BTreeMap::new();
    let mut still: BTreeMap<String, usize> = BTreeMap::new();
    for &i in order {
        let Some(group) = groups[i].clone() else {
            continue;
        };
        if !moved[i] {
            still.insert(group, i);
            continue;
        }
        let m = w_now[i] * w_rest[i].inverse();
        let rotation = DMat3::from_mat4(m);
        let gram = rotation.transpose() * rotation - DMat3::IDENTITY;
        let stray = gram
            .to_cols_array()
            .iter()
            .fold(0.0f64, |a, &c| a.max(c.abs()));
        // (Written to refuse NaN too: a zero rotation or scale at rest makes one.)
        let rigid = m.is_finite()
            && stray <= RIGID_TOLERANCE
            && (rotation.determinant() - 1.0).abs() <= RIGID_TOLERANCE;
        if !rigid {
            return Err(format!(
                "node {i} (mesh {group:?}) is scaled or sheared from where the file places it: not a rigid motion"
            ));
        }
        let pose = Rigid {
            rotation,
            translation: m.w_axis.truncate(),
        };
        match poses.get(&group) {
            Some((other, j)) if !same_pose(other, &pose) => {
                return Err(format!(
                    "mesh {group:?} is placed by nodes {j} and {i}, which move differently: give each node a mesh of its own name"
                ))
            }
            // (The first node's pose stands for the others, which agree to rounding.)
            Some(_) => {}
            None => {
                poses.insert(group.clone(), (pose, i));
            }
        }
    }
    if let Some((group, (_, i))) = poses.iter().find(|(g, _)| still.contains_key(*g)) {
        return Err(format!(
            "mesh {group:?} is placed by node {i}, which moves, and node {}, which does not: give each node a mesh of its own name",
            still[group]
        ));
    }
    Ok(poses.into_iter().map(|(g, (pose, _))| (g, pose)).collect())
}

/// Whether two nodes placing one mesh move it alike: the same pose but for rounding (a
/// mesh placed by several children of one moving node gets `Wp(t) L (Wp L)⁻¹` from each).
fn same_pose(a: &Rigid, b: &Rigid) -> bool {
    const CLOSE: f64 = 1e-9;
    let turn = (a.rotation - b.rotation)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, &c| m.max(c.abs()));
    let size = 1.0 + a.translation.length().max(b.translation.length());
    turn <= CLOSE && (a.translation - b.translation).length() <= CLOSE * size
}
