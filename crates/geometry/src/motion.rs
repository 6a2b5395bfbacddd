//! Rigid motion of a scene's named groups over steps: the motion file (JSON, documented
//! in `docs/formats.md`), checked against the scene, and each step's scene.
//!
//! A step gives each group it moves a pose: a rotation and a translation applied to the
//! group's vertices as written in the scene file (`x' = R (x − about) + about + t`), not
//! to the previous step's; groups a step does not name stay as written. Poses are
//! absolute so that steps do not drift and any step can be made on its own.

use crate::error::Error;
use crate::scene::{PatchGrid, Scene, SceneDesc};
use glam::{DMat3, DQuat, DVec3};
use serde::Deserialize;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// How far a given rotation matrix may stray from a rotation: each entry of `RᵀR − I`
/// within this, and its determinant within this of 1 (matrices written with about seven
/// digits pass; a scale of 1.00001 or a shear does not).
pub const RIGID_TOLERANCE: f64 = 1e-6;

/// The most steps a motion may hold.
pub const MAX_STEPS: usize = 100_000;

/// A rigid transform `x ↦ rotation · x + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    pub rotation: DMat3,
    pub translation: DVec3,
}

impl Rigid {
    pub const IDENTITY: Rigid = Rigid {
        rotation: DMat3::IDENTITY,
        translation: DVec3::ZERO,
    };

    /// A turn by `radians` about the line through `about` along `axis` (right-handed),
    /// then a translation by `translate`.
    pub fn turn(axis: DVec3, radians: f64, about: DVec3, translate: DVec3) -> Rigid {
        let rotation = DMat3::from_axis_angle(axis.normalize(), radians);
        Rigid {
            rotation,
            translation: about - rotation * about + translate,
        }
    }

    pub fn apply(&self, v: DVec3) -> DVec3 {
        self.rotation * v + self.translation
    }
}

/// One step: its name and the pose of each group it moves, by group name.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionStep {
    pub name: String,
    pub poses: BTreeMap<String, Rigid>,
}

/// A motion: steps, each a pose per moved group.
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// The file it was read from (named in errors), or a label for one built in code.
    pub path: PathBuf,
    pub steps: Vec<MotionStep>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileMotion {
    #[serde(default)]
    #[allow(dead_code)]
    description: Option<String>,
    #[serde(default)]
    steps: Option<Vec<FileStep>>,
    /// Poses at given times, interpolated at `times`.
    #[serde(default)]
    keyframes: Option<Vec<FileKeyframe>>,
    #[serde(default)]
    times: Option<Vec<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileKeyframe {
    time: f64,
    #[serde(default)]
    groups: BTreeMap<String, FilePose>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileStep {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    groups: BTreeMap<String, FilePose>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePose {
    #[serde(default)]
    rotate: Option<FileTurn>,
    /// A rotation matrix, row by row.
    #[serde(default)]
    matrix: Option<[[f64; 3]; 3]>,
    /// The point the rotation turns about (the origin if not given).
    #[serde(default)]
    about: Option<[f64; 3]>,
    #[serde(default)]
    translate: Option<[f64; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileTurn {
    axis: [f64; 3],
    degrees: f64,
}

impl Motion {
    /// Reads a motion file (JSON; [`crate::file::read_motion`] reads glTF animations
    /// too).
    pub fn read(path: &Path) -> Result<Motion, Error> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Motion::parse(&text, path)
    }

    /// Parses a motion file's text (`path` names it in errors).
    pub fn parse(text: &str, path: &Path) -> Result<Motion, Error> {
        let file: FileMotion = serde_json::from_str(text).map_err(|e| Error::Json {
            path: path.to_path_buf(),
            line: e.line(),
            column: e.column(),
            message: e.to_string(),
        })?;
        let fail = |message: String| Error::Motion {
            path: path.to_path_buf(),
            message,
        };
        let steps = match (file.steps, file.keyframes, file.times) {
            (Some(steps), None, None) => file_steps(steps),
            (None, Some(keys), Some(times)) => keyframed(keys, &times),
            (None, Some(_), None) => {
                Err("\"keyframes\" need \"times\": the times at which to make steps".into())
            }
            (None, None, Some(_)) => {
                Err("\"times\" need \"keyframes\": the poses to interpolate".into())
            }
            (None, None, None) => Err(
                "the motion has no steps (give \"steps\", or \"keyframes\" and \"times\")".into(),
            ),
            (Some(_), _, _) => {
                Err("give \"steps\", or \"keyframes\" and \"times\", not both".into())
            }
        }
        .map_err(fail)?;
        Ok(Motion {
            path: path.to_path_buf(),
            steps,
        })
    }

    /// Checks that every group the motion moves is a group of `desc` (the JSON
    /// format's `group`, an OBJ or glTF object, a View3D surface).
    pub fn check(&self, desc: &SceneDesc) -> Result<(), Error> {
        let known: BTreeSet<&str> = desc
            .polygons
            .iter()
            .filter_map(|p| p.group.as_deref())
            .collect();
        for (k, step) in self.steps.iter().enumerate() {
            if let Some(g) = step.poses.keys().find(|g| !known.contains(g.as_str())) {
                let listed: Vec<&str> = known.iter().take(8).copied().collect();
                let more = if known.len() > 8 { ", ..." } else { "" };
                return Err(Error::Motion {
                    path: self.path.clone(),
                    message: format!(
                        "step {k} ({:?}) moves group {g:?}, which the scene does not have (its groups: {}{more})",
                        step.name,
                        if listed.is_empty() {
                            "none: give polygons a \"group\"".to_string()
                        } else {
                            format!("{listed:?}")
                        }
                    ),
                });
            }
        }
        Ok(())
    }

    /// `base` at step `k`: the vertices of every polygon of a group the step moves,
    /// transformed (in f64) by its pose.
    pub fn step_desc(&self, base: &SceneDesc, k: usize) -> SceneDesc {
        let poses = &self.steps[k].poses;
        let mut desc = base.clone();
        for p in &mut desc.polygons {
            if let Some(pose) = p.group.as_deref().and_then(|g| poses.get(g)) {
                for v in &mut p.vertices {
                    *v = pose.apply(*v);
                }
            }
        }
        desc
    }

    /// The unit every step's rows are made in ([`Scene::with_unit`]): the largest
    /// coordinate of any step's scene. One unit for all steps keeps the bits of every
    /// polygon that did not move (a step's own largest coordinate may change in its
    /// last place as an array turns); a step's rows equal those of its scene made on
    /// its own wherever that scene's largest coordinate is this one (else they may
    /// differ as rows of a scaled scene do: in cells whose rays pass within rounding of
    /// an edge).
    pub fn unit(&self, base: &SceneDesc) -> f64 {
        let still = base
            .polygons
            .iter()
            .filter(|p| p.group.is_none())
            .flat_map(|p| &p.vertices)
            .fold(0.0f64, |m, v| m.max(v.abs().max_element()));
        let mut unit = still;
        for step in &self.steps {
            for p in &base.polygons {
                let pose = p.group.as_deref().and_then(|g| step.poses.get(g));
                for v in &p.vertices {
                    let v = pose.map_or(*v, |r| r.apply(*v));
                    unit = unit.max(v.abs().max_element());
                }
            }
        }
        unit
    }

    /// The validated scene of step `k` in `unit` ([`Motion::unit`]), each polygon cut
    /// as in `cut` (the scene of `base`, so that a turned polygon keeps its patches):
    /// an error names the step and the groups it moves (a moved polygon laid over a
    /// coplanar one, say).
    pub fn step_scene(
        &self,
        base: &SceneDesc,
        cut: &Scene,
        k: usize,
        unit: f64,
    ) -> Result<Scene, Error> {
        let mut desc = self.step_desc(base, k);
        for (pd, p) in desc.polygons.iter_mut().zip(cut.polygons()) {
            let (nu, nv) = p.grid();
            pd.grid = PatchGrid::Cells {
                nu: u64::from(nu),
                nv: u64::from(nv),
            };
        }
        let step = &self.steps[k];
        let wrap = |source: Error| Error::MotionStep {
            path: self.path.clone(),
            step: k,
            name: step.name.clone(),
            groups: step.poses.keys().cloned().collect::<Vec<_>>().join(", "),
            source: Box::new(source),
        };
        let scene = Scene::with_unit(desc, unit).map_err(wrap)?;
        if scene.patches().len() != cut.patches().len() {
            return Err(wrap(Error::Motion {
                path: self.path.clone(),
                message: format!(
                    "the step's scene has {} patches where the scene has {}",
                    scene.patches().len(),
                    cut.patches().len()
                ),
            }));
        }
        Ok(scene)
    }
}

impl Motion {
    /// The motion as a motion file: each pose as its rotation matrix (row by row) and
    /// translation, in the shortest decimals that read back to the same f64 (so the
    /// file reads back to this motion, to the bit).
    pub fn to_json(&self, description: Option<&str>) -> String {
        let text = |v: serde_json::Value| v.to_string();
        let mut out = String::from("{\n");
        if let Some(d) = description {
            out += &format!("  \"description\": {},\n", text(d.into()));
        }
        out += "  \"steps\": [\n";
        for (k, step) in self.steps.iter().enumerate() {
            out += &format!(
                "    {{\"name\": {}, \"groups\": {{",
                text(step.name.as_str().into())
            );
            for (n, (g, r)) in step.poses.iter().enumerate() {
                let pose = serde_json::json!({
                    "matrix": r.rotation.transpose().to_cols_array_2d(),
                    "translate": r.translation.to_array(),
                });
                let sep = if n == 0 { "" } else { "," };
                out += &format!("{sep}\n      {}: {}", text(g.as_str().into()), text(pose));
            }
            let end = if k + 1 == self.steps.len() { "" } else { "," };
            out += &format!("\n    }}}}{end}\n");
        }
        out += "  ]\n}\n";
        out
    }
}

/// A motion file's steps, each pose checked.
fn file_steps(file: Vec<FileStep>) -> Result<Vec<MotionStep>, String> {
    check_count(file.len())?;
    let mut steps = Vec::with_capacity(file.len());
    for (k, step) in file.into_iter().enumerate() {
        let name = step.name.unwrap_or_else(|| format!("step {k}"));
        let mut poses = BTreeMap::new();
        for (group, pose) in step.groups {
            let pose = pose_of(&pose)
                .map_err(|why| format!("step {k} ({name:?}), group {group:?}: {why}"))?;
            poses.insert(group, pose.rigid());
        }
        steps.push(MotionStep { name, poses });
    }
    Ok(steps)
}

/// Refuses no steps, or more than [`MAX_STEPS`].
fn check_count(n: usize) -> Result<(), String> {
    match n {
        0 => Err("the motion has no steps".into()),
        n if n > MAX_STEPS => Err(format!(
            "the motion has {n} steps, over the limit of {MAX_STEPS}"
        )),
        _ => Ok(()),
    }
}

/// The largest turn between two keyframes of a group, degrees: past it the shorter way
/// round is ill-defined (at 180° there are two), so a keyframe must come between.
pub const MAX_KEYFRAME_TURN_DEGREES: f64 = 179.0;

/// Steps at `times` from keyframes: each group's pose interpolated between the two
/// keyframes that name it around the time (rotation by the shorter arc, the pivot and
/// the translation in a straight line), held before its first keyframe and after its
/// last; at a keyframe's time, that keyframe's pose, to the bit.
fn keyframed(keys: Vec<FileKeyframe>, times: &[f64]) -> Result<Vec<MotionStep>, String> {
    if keys.is_empty() {
        return Err("\"keyframes\" is empty".into());
    }
    check_count(times.len())?;
    let mut tracks: BTreeMap<String, Vec<(f64, Pose)>> = BTreeMap::new();
    let mut last = f64::NEG_INFINITY;
    for (k, key) in keys.iter().enumerate() {
        if !key.time.is_finite() || key.time <= last {
            return Err(format!(
                "keyframe {k}: time {} is not finite or not after the keyframe before's ({last}); keyframes go in increasing time",
                key.time
            ));
        }
        last = key.time;
        for (group, pose) in &key.groups {
            let pose = pose_of(pose).map_err(|why| {
                format!("keyframe {k} (time {}), group {group:?}: {why}", key.time)
            })?;
            let track = tracks.entry(group.clone()).or_default();
            if let Some((t0, before)) = track.last() {
                let turn = before.turn_to(&pose).to_degrees();
                if turn > MAX_KEYFRAME_TURN_DEGREES {
                    return Err(format!(
                        "group {group:?} turns {turn:.2}° between times {t0} and {}: over {MAX_KEYFRAME_TURN_DEGREES}° the way round is ambiguous; add a keyframe between",
                        key.time
                    ));
                }
            }
            track.push((key.time, pose));
        }
    }
    if let Some((i, t)) = times.iter().enumerate().find(|(_, t)| !t.is_finite()) {
        return Err(format!("times[{i}] = {t} is not finite"));
    }
    Ok(times
        .iter()
        .map(|&t| MotionStep {
            name: format!("t = {t}"),
            poses: tracks
                .iter()
                .map(|(group, track)| (group.clone(), pose_at(track, t).rigid()))
                .collect(),
        })
        .collect())
}

/// A group's pose at time `t` from its keyframes (in increasing time).
fn pose_at(track: &[(f64, Pose)], t: f64) -> Pose {
    let after = track.partition_point(|(time, _)| *time <= t);
    if after == 0 {
        return track[0].1;
    }
    let (t0, a) = track[after - 1];
    if after == track.len() || t0 == t {
        return a;
    }
    let (t1, b) = track[after];
    if a == b {
        return a;
    }
    a.towards(&b, (t - t0) / (t1 - t0))
}

/// A pose as a file gives it: `x' = R (x − about) + about + translate`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Pose {
    rotation: DMat3,
    about: DVec3,
    translate: DVec3,
}

impl Pose {
    fn rigid(&self) -> Rigid {
        Rigid {
            rotation: self.rotation,
            translation: self.about - self.rotation * self.about + self.translate,
        }
    }

    /// The angle of the rotation from this pose's to `other`'s, radians.
    fn turn_to(&self, other: &Pose) -> f64 {
        let (a, b) = (
            DQuat::from_mat3(&self.rotation),
            DQuat::from_mat3(&other.rotation),
        );
        2.0 * a.dot(b).abs().min(1.0).acos()
    }

    /// The pose a share `s` (in (0, 1)) of the way to `other`.
    fn towards(&self, other: &Pose, s: f64) -> Pose {
        let rotation = if self.rotation == other.rotation {
            // (A group that only slides keeps its rotation's bits.)
            self.rotation
        } else {
            let a = DQuat::from_mat3(&self.rotation).normalize();
            let b = DQuat::from_mat3(&other.rotation).normalize();
            // (The shorter arc: q and −q are one rotation.)
            let b = if a.dot(b) < 0.0 { -b } else { b };
            DMat3::from_quat(a.slerp(b, s).normalize())
        };
        Pose {
            rotation,
            about: self.about.lerp(other.about, s),
            translate: self.translate.lerp(other.translate, s),
        }
    }
}

/// The pose a file gives, or why it is none.
fn pose_of(pose: &FilePose) -> Result<Pose, String> {
    let finite = |what: &str, v: &[f64]| {
        if v.iter().all(|c| c.is_finite()) {
            Ok(())
        } else {
            Err(format!("{what} {v:?} is not finite"))
        }
    };
    let about = DVec3::from(pose.about.unwrap_or([0.0; 3]));
    let translate = DVec3::from(pose.translate.unwrap_or([0.0; 3]));
    finite("\"about\"", &about.to_array())?;
    finite("\"translate\"", &translate.to_array())?;
    let rotation = match (&pose.rotate, &pose.matrix) {
        (Some(_), Some(_)) => {
            return Err("give \"rotate\" or \"matrix\", not both".into());
        }
        (Some(turn), None) => {
            finite("\"axis\"", &turn.axis)?;
            finite("\"degrees\"", &[turn.degrees])?;
            let axis = DVec3::from(turn.axis);
            if axis.length() < 1e-12 {
                return Err(format!("\"axis\" {:?} has no direction", turn.axis));
            }
            DMat3::from_axis_angle(axis.normalize(), turn.degrees.to_radians())
        }
        (None, Some(rows)) => {
            for row in rows {
                finite("\"matrix\" row", row)?;
            }
            let m = DMat3::from_cols_array_2d(rows).transpose();
            check_rotation(&m)?;
            m
        }
        (None, None) => DMat3::IDENTITY,
    };
    Ok(Pose {
        rotation,
        about,
        translate,
    })
}

/// Whether `m` is a rotation within [`RIGID_TOLERANCE`].
fn check_rotation(m: &DMat3) -> Result<(), String> {
    let gram = m.transpose() * *m - DMat3::IDENTITY;
    let stray = gram
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, &c| a.max(c.abs()));
    if stray > RIGID_TOLERANCE {
        return Err(format!(
            "\"matrix\" is not a rotation: it scales or shears (RᵀR differs from the identity by {stray:.3e}, over {RIGID_TOLERANCE:e}); a motion is rigid"
        ));
    }
    let det = m.determinant();
    if (det - 1.0).abs() > RIGID_TOLERANCE {
        return Err(format!(
            "\"matrix\" has determinant {det:.6}: a reflection, not a rotation; a motion is rigid"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::cube;

    fn parse(text: &str) -> Result<Motion, Error> {
        Motion::parse(text, Path::new("m.json"))
    }

    #[test]
    fn a_turn_about_a_point_moves_as_written() {
        let m = parse(
            r#"{"steps": [{"name": "a", "groups": {"g": {"rotate": {"axis": [0, 0, 2], "degrees": 90},
                 "about": [1, 0, 0], "translate": [0, 0, 5]}}}, {}]}"#,
        )
        .unwrap();
        assert_eq!(m.steps.len(), 2);
        assert_eq!(m.steps[1].name, "step 1");
        let r = m.steps[0].poses["g"];
        let p = r.apply(DVec3::new(2.0, 0.0, 0.0));
        assert!((p - DVec3::new(1.0, 1.0, 5.0)).length() < 1e-12, "{p}");
        assert!((r.apply(DVec3::new(1.0, 0.0, 0.0)) - DVec3::new(1.0, 0.0, 5.0)).length() < 1e-12);
    }

    #[test]
    fn a_written_motion_reads_back_to_the_bit() {
        let m = crate::scenes::satellite_motion(36);
        let mut back =
            Motion::parse(&m.to_json(Some("arrays")), Path::new("satellite motion")).unwrap();
        back.path = m.path.clone();
        assert_eq!(back, m);
    }

    #[test]
    fn a_matrix_must_be_a_rotation() {
        let ok = parse(
            r#"{"steps": [{"groups": {"g": {"matrix": [[0, -1, 0], [1, 0, 0], [0, 0, 1]]}}}]}"#,
        )
        .unwrap();
        let p = ok.steps[0].poses["g"].apply(DVec3::X);
        assert!((p - DVec3::Y).length() < 1e-15, "rows are rows: {p}");
        for (matrix, says) in [
            ("[[1.01, 0, 0], [0, 1, 0], [0, 0, 1]]", "scales or shears"),
            ("[[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]", "scales or shears"),
            ("[[-1, 0, 0], [0, 1, 0], [0, 0, 1]]", "reflection"),
        ] {
            let text = format!(
                r#"{{"steps": [{{}}, {{"name": "s", "groups": {{"arm": {{"matrix": {matrix}}}}}}}]}}"#
            );
            let e = parse(&text).unwrap_err().to_string();
            assert!(
                e.contains(says) && e.contains("step 1") && e.contains("\"arm\""),
                "{e}"
            );
        }
    }

    #[test]
    fn malformed_motions_are_refused_by_place() {
        for (text, says) in [
            ("{\"steps\": [", "m.json:1:"),
            (r#"{"steps": []}"#, "no steps"),
            (
                r#"{"steps": [{"groups": {"g": {"spin": 1}}}]}"#,
                "unknown field",
            ),
            (
                r#"{"steps": [{"groups": {"g": {"rotate": {"axis": [0, 0, 0], "degrees": 3}}}}]}"#,
                "no direction",
            ),
            (
                r#"{"steps": [{"groups": {"g": {"rotate": {"axis": [0, 0, 1], "degrees": 3}, "matrix": [[1,0,0],[0,1,0],[0,0,1]]}}}]}"#,
                "not both",
            ),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn an_unknown_group_is_named_with_the_step() {
        let mut desc = cube(1);
        desc.polygons[0].group = Some("lid".into());
        let m =
            parse(r#"{"steps": [{"groups": {"lid": {}}}, {"name": "b", "groups": {"door": {}}}]}"#)
                .unwrap();
        let e = m.check(&desc).unwrap_err().to_string();
        assert!(
            e.contains("step 1") && e.contains("\"door\"") && e.contains("\"lid\""),
            "{e}"
        );
    }

    #[test]
    fn a_step_that_lays_a_polygon_over_another_names_the_step() {
        let mut desc = cube(2);
        desc.polygons[0].group = Some("lid".into());
        let scene = Scene::new(desc.clone()).unwrap();
        // Face 0 (y = 0, facing +y) turned half about x through the centre lies on face
        // 1 (y = 1, facing −y), the same square facing the same way.
        let lid = Rigid::turn(
            DVec3::X,
            std::f64::consts::PI,
            DVec3::splat(0.5),
            DVec3::ZERO,
        );
        let m = Motion {
            path: "m.json".into(),
            steps: vec![MotionStep {
                name: "onto".into(),
                poses: BTreeMap::from([("lid".into(), lid)]),
            }],
        };
        let e = m
            .step_scene(&desc, &scene, 0, m.unit(&desc))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("step 0")
                && e.contains("\"onto\"")
                && e.contains("lid")
                && e.contains("overlap"),
            "{e}"
        );
    }

    #[test]
    fn keyframes_are_interpolated_about_their_pivot_and_held_outside() {
        // A hinge about the z axis through (1, 0, 0): 0° at t = 0, 90° at t = 2; a cart
        // from 0 to 4 along x between t = 1 and t = 3.
        let m = parse(
            r#"{"keyframes": [
                {"time": 0, "groups": {"hinge": {"rotate": {"axis": [0, 0, 1], "degrees": 0}, "about": [1, 0, 0]}}},
                {"time": 1, "groups": {"cart": {}}},
                {"time": 2, "groups": {"hinge": {"rotate": {"axis": [0, 0, 1], "degrees": 90}, "about": [1, 0, 0]}}},
                {"time": 3, "groups": {"cart": {"translate": [4, 0, 0]}}}],
              "times": [-1, 0, 1, 2, 2.5, 4]}"#,
        )
        .unwrap();
        assert_eq!(m.steps.len(), 6);
        assert_eq!(m.steps[4].name, "t = 2.5");
        let at = |k: usize, g: &str, p: [f64; 3]| m.steps[k].poses[g].apply(DVec3::from(p));
        // Halfway (t = 1): 45° about the pivot, the pivot fixed.
        let half = std::f64::consts::FRAC_1_SQRT_2;
        assert!(
            (at(2, "hinge", [2.0, 0.0, 0.0]) - DVec3::new(1.0 + half, half, 0.0)).length() < 1e-12
        );
        assert!((at(2, "hinge", [1.0, 0.0, 0.0]) - DVec3::X).length() < 1e-12);
        // At a keyframe's time, its pose to the bit; held before the first and after
        // the last.
        let turn = Rigid::turn(DVec3::Z, 90f64.to_radians(), DVec3::X, DVec3::ZERO);
        assert_eq!(m.steps[3].poses["hinge"], turn);
        assert_eq!(m.steps[4].poses["hinge"], turn);
        assert_eq!(m.steps[5].poses["hinge"], turn);
        assert_eq!(m.steps[0].poses["hinge"], m.steps[1].poses["hinge"]);
        assert_eq!(m.steps[0].poses["cart"], Rigid::IDENTITY);
        assert_eq!(m.steps[2].poses["cart"], Rigid::IDENTITY);
        assert!((at(3, "cart", [0.0; 3]) - DVec3::new(2.0, 0.0, 0.0)).length() < 1e-12);
        assert!((at(4, "cart", [0.0; 3]) - DVec3::new(3.0, 0.0, 0.0)).length() < 1e-12);
        assert_eq!(
            m.steps[5].poses["cart"].translation,
            DVec3::new(4.0, 0.0, 0.0)
        );
        // A group held between two equal keyframes keeps its pose to the bit.
        let m = parse(
            r#"{"keyframes": [
                {"time": 0, "groups": {"g": {"rotate": {"axis": [1, 2, 3], "degrees": 37}}}},
                {"time": 1, "groups": {"g": {"rotate": {"axis": [1, 2, 3], "degrees": 37}}}}],
              "times": [0, 0.3, 0.7, 1]}"#,
        )
        .unwrap();
        assert!(m
            .steps
            .iter()
            .all(|s| s.poses["g"] == m.steps[0].poses["g"]));
    }

    #[test]
    fn bad_keyframes_are_refused_by_place() {
        for (text, says) in [
            (r#"{"keyframes": [{"time": 0}]}"#, "need \"times\""),
            (r#"{"times": [0]}"#, "need \"keyframes\""),
            (
                r#"{"steps": [{}], "keyframes": [{"time": 0}], "times": [0]}"#,
                "not both",
            ),
            (r#"{"keyframes": [], "times": [0]}"#, "is empty"),
            (r#"{"keyframes": [{"time": 0}], "times": []}"#, "no steps"),
            (
                r#"{"keyframes": [{"time": 1}, {"time": 1}], "times": [0]}"#,
                "keyframe 1: time 1",
            ),
            (
                r#"{"keyframes": [{"time": 0, "groups": {"g": {"matrix": [[2, 0, 0], [0, 1, 0], [0, 0, 1]]}}}], "times": [0]}"#,
                "keyframe 0 (time 0), group \"g\"",
            ),
            (
                r#"{"keyframes": [{"time": 0, "groups": {"g": {}}},
                    {"time": 1, "groups": {"g": {"rotate": {"axis": [0, 1, 0], "degrees": 180}}}}], "times": [0]}"#,
                "group \"g\" turns 180.00° between times 0 and 1",
            ),
        ] {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
    }
}
