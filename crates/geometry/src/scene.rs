//! Scenes: validated polygons with their patches, materials and an optional camera.

use crate::error::{Error, PolygonProblem};
use crate::facets::Facets;
use crate::hit_test::OriginTerms;
use crate::polygon::{Patch, Polygon};
use glam::{DVec3, Vec3};
use rad_core::{Hit, PatchId, PolygonId, Ray, Rgb};

/// Largest number of patches a scene may have.
pub const MAX_PATCHES: u64 = 1 << 26;

/// A diffuse material: reflectance in [0, 1) and emission (exitance, W·m⁻²) ≥ 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub reflectance: Rgb,
    pub emission: Rgb,
}

/// How a polygon's patch texture is cut.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PatchGrid {
    /// Exactly `nu × nv` cells.
    Cells { nu: u64, nv: u64 },
    /// Cells about `size` long on each edge: `nu = max(1, round(|e_u| / size))`, same for v
    /// (halves rounded up, and counts within a millionth of themselves (at most a
    /// thousandth of a cell) below a half).
    Size(f64),
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
}

impl Camera {
    /// What makes this camera unusable, if anything: non-finite vectors, `up` parallel
    /// to the view direction, or a field of view outside (0, π).
    pub fn problem(&self) -> Option<String> {
        let fin = self.position.is_finite() && self.look_at.is_finite() && self.up.is_finite();
        let dir = self.look_at - self.position;
        if !fin
            || dir.length() == 0.0
            || dir.cross(self.up).length() <= 1e-6 * dir.length() * self.up.length()
        {
            return Some(
                "needs finite position, look_at and up, with up not parallel to the view direction"
                    .into(),
            );
        }
        if !(self.fov_y > 0.0 && self.fov_y < std::f32::consts::PI) {
            return Some(format!(
                "field of view {} rad is not in (0, pi)",
                self.fov_y
            ));
        }
        None
    }
}

/// One polygon as described, before validation.
#[derive(Clone, Debug, PartialEq)]
pub struct PolygonDesc {
    pub name: String,
    /// As given, in f64. The scene's polygons hold them rounded to f32; its rows are
    /// made from them divided by the scene's largest coordinate first
    /// ([`Scene::for_rows`]), so that rows do not depend on the scene's scale.
    pub vertices: Vec<DVec3>,
    /// Index into [`SceneDesc::materials`].
    pub material: usize,
    pub grid: PatchGrid,
    /// The surface it belongs to, for surface-level view factors (`--by group`): the
    /// JSON format's `group`, an OBJ file's object or group.
    pub group: Option<String>,
    /// An obstruction only (the JSON format's `obstruction`, View3D's O surfaces): it
    /// blocks rays like any polygon, but view factors give it no row and no column.
    pub obstruction: bool,
    /// Seen, lit and shading from both sides (the JSON format's `two_sided`): the scene
    /// makes it two back-to-back polygons, this one and its reverse (named `NAME:back`,
    /// in group `GROUP:back`, appended after every described polygon), each seen only
    /// from its front ([`Polygon::front_only`]), so each side has its own patches.
    pub two_sided: bool,
}

/// A scene as described, before validation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneDesc {
    pub materials: Vec<Material>,
    pub polygons: Vec<PolygonDesc>,
    pub camera: Option<Camera>,
}

/// A validated scene: polygons, their patches (numbered polygon by polygon), materials
/// and an optional camera.
#[derive(Clone, Debug)]
pub struct Scene {
    polygons: Vec<Polygon>,
    patches: Vec<Patch>,
    materials: Vec<Material>,
    camera: Option<Camera>,
    bounds: (Vec3, Vec3),
    groups: Vec<Option<String>>,
    obstructions: Vec<bool>,
    /// Each polygon's [`Polygon::reach`] if it is front-only, else −∞; empty when no
    /// polygon is (what [`Scene::seen`] reads).
    front_only: Vec<f32>,
    /// By polygon, together (what an item buffer's runs read, [`Scene::seen_terms`]):
    /// its plane and its patch, or [`SEVERAL`] for a polygon of several.
    seen_terms: Vec<SeenTerms>,
    /// The polygons across each edge, made on first use.
    edges: std::sync::OnceLock<crate::EdgeNeighbours>,
    /// Its facets, made on first use.
    facets: std::sync::OnceLock<crate::Facets>,
    /// Where the largest coordinate is not a power of two: the description divided by
    /// it (patch grids as this scene cut them), and the scene it makes, on first use
    /// ([`Scene::for_rows`]).
    unit_desc: Option<(f64, Box<SceneDesc>)>,
    unit_scene: std::sync::OnceLock<Result<Box<Scene>, String>>,
}

/// [`SeenTerms::patch`] of a polygon of several patches.
pub const SEVERAL: PatchId = PatchId::MAX;

/// What an item buffer needs of the polygon a run of cells sees, 20 bytes together:
/// its plane `normal · p = plane_d` ([`Polygon::plane_num`] from them gives the same
/// bits), and its patch where it has one ([`Polygon::one_patch`]), else [`SEVERAL`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeenTerms {
    pub normal: Vec3,
    pub plane_d: f32,
    pub patch: PatchId,
}

impl SeenTerms {
    fn of(p: &Polygon) -> SeenTerms {
        let terms = p.terms();
        SeenTerms {
            normal: terms.normal,
            plane_d: terms.plane_d,
            patch: p.one_patch().unwrap_or(SEVERAL),
        }
    }

    /// [`Polygon::plane_num`].
    #[inline]
    pub fn plane_num(&self, o: Vec3) -> f32 {
        self.plane_d - self.normal.dot(o)
    }
}

impl Scene {
    /// Validates a description and builds every polygon's patch texture.
    pub fn new(desc: SceneDesc) -> Result<Scene, Error> {
        Scene::build(desc, &[], None)
    }

    /// [`Scene::new`], its rows made from the description divided by `unit` rather than
    /// by its own largest coordinate ([`Scene::for_rows`]): what a motion's steps share
    /// ([`crate::Motion::unit`]), so that a polygon that did not move keeps its bits
    /// from step to step. `unit` must be finite and > 0.
    pub fn with_unit(desc: SceneDesc, unit: f64) -> Result<Scene, Error> {
        if !(unit.is_finite() && unit > 0.0) {
            return Err(Error::Divided {
                unit,
                message: "the unit must be finite and > 0".into(),
            });
        }
        Scene::build(desc, &[], Some(unit))
    }

    /// [`Scene::new`], the back sides of two-sided polygons cut by `back_grids` in
    /// order where given (the divided scene's, cut as the scene's were, not anew).
    fn build(desc: SceneDesc, back_grids: &[PatchGrid], unit: Option<f64>) -> Result<Scene, Error> {
        // (Kept before validation: the polygons below are built from its vertices.)
        let unit_desc = divided(&desc, unit.unwrap_or_else(|| desc.largest_coordinate()));
        // (How polygons are cut is decided on the vertices divided by the largest
        // coordinate, the divided scene's: so a scene cuts alike at any scale.)
        let unit = structure_unit(&desc);
        check_materials(&desc.materials)?;
        if desc.polygons.is_empty() {
            return Err(Error::Empty);
        }
        if let Some(problem) = desc.camera.as_ref().and_then(Camera::problem) {
            return Err(Error::Camera { problem });
        }
        let described = desc.polygons.len();
        // Two-sided polygons' back sides come after every described polygon, so that
        // the described ones keep their indices (the file's, in errors and outputs).
        let backs = back_sides(&desc, unit, back_grids);
        check_patch_count(&desc, &backs, unit)?;
        let mut polygons = Vec::with_capacity(described + backs.len());
        let mut patches: Vec<Patch> = Vec::new();
        let mut groups = Vec::with_capacity(described + backs.len());
        let mut obstructions = Vec::with_capacity(described + backs.len());
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        // (The file's index of each polygon, a back's its front's: what errors name.)
        let mut file_index = Vec::with_capacity(described + backs.len());
        let all = desc.polygons.into_iter().enumerate().chain(backs);
        for (idx, pd) in all {
            let fail = |name: &str, problem| Error::Polygon {
                polygon: idx,
                name: name.to_string(),
                problem,
            };
            if pd.two_sided && pd.obstruction {
                return Err(fail(&pd.name, PolygonProblem::TwoSidedObstruction));
            }
            if pd.material >= desc.materials.len() {
                return Err(fail(
                    &pd.name,
                    PolygonProblem::MaterialIndexOutOfRange {
                        index: pd.material,
                        len: desc.materials.len(),
                    },
                ));
            }
            let (nu, nv) = grid_cells(&pd, unit).map_err(|p| fail(&pd.name, p))?;
            if nu.saturating_mul(nv) > crate::polygon::MAX_CELLS_PER_POLYGON {
                let limit = crate::polygon::MAX_CELLS_PER_POLYGON;
                return Err(fail(
                    &pd.name,
                    PolygonProblem::PatchGridTooLarge { nu, nv, limit },
                ));
            }
            if patches.len() as u64 + nu.saturating_mul(nv) > MAX_PATCHES {
                return Err(Error::TooManyPatches {
                    count: patches.len() as u64 + nu.saturating_mul(nv),
                    limit: MAX_PATCHES,
                });
            }
            let name = pd.name.clone();
            groups.push(pd.group);
            obstructions.push(pd.obstruction);
            let mut built = Polygon::build(
                pd.name,
                rounded(&pd.vertices),
                pd.material as u32,
                nu,
                nv,
                patches.len() as PatchId,
            )
            .map_err(|p| fail(&name, p))?;
            built.polygon.set_front_only(pd.two_sided);
            for v in built.polygon.vertices() {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
            let id = polygons.len() as u32;
            file_index.push(idx);
            patches.extend(built.patches.into_iter().map(|mut p| {
                p.polygon = id;
                p
            }));
            polygons.push(built.polygon);
        }
        let front_only = front_only_reaches(&polygons);
        let extent = (hi - lo).length() as f64;
        if let Some((a, b, area)) = crate::overlap::find_overlap(&polygons, extent) {
            return Err(Error::Overlap {
                a: file_index[a],
                a_name: polygons[a].name().to_string(),
                b: file_index[b],
                b_name: polygons[b].name().to_string(),
                area,
            });
        }
        let unit_desc = unit_desc.map(|(unit, d)| (unit, cut_alike(d, &polygons)));
        let seen_terms = polygons.iter().map(SeenTerms::of).collect();
        Ok(Scene {
            polygons,
            patches,
            materials: desc.materials,
            camera: desc.camera,
            bounds: (lo, hi),
            groups,
            obstructions,
            front_only,
            seen_terms,
            edges: std::sync::OnceLock::new(),
            facets: std::sync::OnceLock::new(),
            unit_desc,
            unit_scene: std::sync::OnceLock::new(),
        })
    }

    /// The scene rows are made from: this scene divided by its largest coordinate (in
    /// f64, from the vertices as described, then rounded to f32), made on the first
    /// call; this scene itself where that coordinate is a power of two (dividing by one
    /// changes no f32 operation of the ray tests but by that power). Its polygons and
    /// patches are this scene's, numbered alike; only its lengths differ. Form factors
    /// are ratios of lengths, and a scene scaled by any factor divides into the same
    /// f32 coordinates (but where the f64 quotient lies within a few units of its last
    /// place of an f32 rounding boundary): so the rows made from it are the same
    /// whatever the scene's scale, where the scene's own f32 coordinates would round
    /// differently at each scale and move the cells whose rays pass within rounding of
    /// an edge.
    pub fn for_rows(&self) -> Result<&Scene, Error> {
        let Some((unit, desc)) = &self.unit_desc else {
            return Ok(self);
        };
        let made = self.unit_scene.get_or_init(|| {
            // (Back sides cut as this scene's: a many-sided back's own frame may run
            // along another edge than its front's.)
            let backs = self.polygons.get(desc.polygons.len()..).unwrap_or(&[]);
            let cells = |p: &Polygon| {
                let (nu, nv) = p.grid();
                PatchGrid::Cells {
                    nu: u64::from(nu),
                    nv: u64::from(nv),
                }
            };
            let backs: Vec<PatchGrid> = backs.iter().map(cells).collect();
            let scene = Scene::build((**desc).clone(), &backs, None).map_err(|e| e.to_string())?;
            let polygons_alike = |a: &Polygon, b: &Polygon| {
                a.grid() == b.grid()
                    && a.first_patch() == b.first_patch()
                    && a.front_only() == b.front_only()
            };
            let alike = scene.patches.len() == self.patches.len()
                && scene.polygons.len() == self.polygons.len()
                && scene.obstructions == self.obstructions
                && (scene.polygons.iter().zip(&self.polygons)).all(|(a, b)| polygons_alike(a, b))
                && (scene.patches.iter().zip(&self.patches))
                    .all(|(a, b)| a.polygon == b.polygon && a.cell == b.cell);
            if alike {
                Ok(Box::new(scene))
            } else {
                Err("its patches are not the scene's".to_string())
            }
        });
        match made {
            Ok(scene) => Ok(scene),
            Err(message) => Err(Error::Divided {
                unit: *unit,
                message: message.clone(),
            }),
        }
    }

    pub fn polygons(&self) -> &[Polygon] {
        &self.polygons
    }
    pub fn patches(&self) -> &[Patch] {
        &self.patches
    }
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }
    /// Whether polygon `polygon` is an obstruction only ([`PolygonDesc::obstruction`]).
    pub fn is_obstruction(&self, polygon: usize) -> bool {
        self.obstructions.get(polygon).copied().unwrap_or(false)
    }
    /// The group polygon `polygon` belongs to, if it names one.
    pub fn group(&self, polygon: usize) -> Option<&str> {
        self.groups.get(polygon).and_then(|g| g.as_deref())
    }
    /// Polygon `p`'s terms for an origin (`terms`, [`crate::PolygonTerms::at`]) as every
    /// caster must test them: a front-only polygon's give no hit from an origin that is
    /// not in front of its plane by more than its reach ([`OriginTerms::front_only`];
    /// [`Polygon::terms_at`] is the same for one polygon).
    #[inline(always)]
    pub fn seen(&self, p: usize, terms: OriginTerms) -> OriginTerms {
        match self.front_only.get(p) {
            Some(&reach) => terms.front_only(reach),
            None => terms,
        }
    }
    /// The polygon across each polygon's edge ([`crate::EdgeNeighbours`]), made on the
    /// first call (a hash of every edge: about 50 ms for 100,000 triangles).
    pub fn edge_neighbours(&self) -> &crate::EdgeNeighbours {
        self.edges
            .get_or_init(|| crate::EdgeNeighbours::of(&self.polygons))
    }
    /// Its facets ([`crate::Facets`]), made on the first call.
    pub fn facets(&self) -> &crate::Facets {
        self.facets.get_or_init(|| crate::Facets::of(self))
    }
    /// By polygon: its plane and its one patch ([`SeenTerms`]), 20 bytes each, for
    /// loops that visit polygons in scattered order.
    #[inline]
    pub fn seen_terms(&self) -> &[SeenTerms] {
        &self.seen_terms
    }

    /// Whether some polygon is front-only (a side of a two-sided polygon).
    pub fn has_front_only(&self) -> bool {
        !self.front_only.is_empty()
    }
    pub fn camera(&self) -> Option<&Camera> {
        self.camera.as_ref()
    }
    /// Axis-aligned bounds of all vertices (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }
    /// Its largest coordinate plus its diagonal (0 for no polygons): ray trees send
    /// rays from origins beyond ten times this to brute force, and grow boxes by 1e-4
    /// of it.
    pub fn scale(&self) -> f32 {
        let vs = self
            .polygons
            .iter()
            .flat_map(|p| p.vertices().iter().copied());
        let (lo, hi) = vs.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        if self.polygons.is_empty() {
            0.0
        } else {
            lo.abs().max(hi.abs()).max_element() + (hi - lo).length()
        }
    }
    /// Material of a patch.
    pub fn patch_material(&self, patch: PatchId) -> &Material {
        let poly = self.patches[patch as usize].polygon;
        &self.materials[self.polygons[poly as usize].material() as usize]
    }

    /// Every polygon `ray` crosses with `0 < t < ray.t_max` but `ray.skip`, sorted by
    /// `t` (ties by id), into `out` after clearing it: brute force, each polygon by the
    /// shared hit test (what accelerators answer `all_hits` with).
    pub fn all_hits(&self, ray: &Ray, out: &mut Vec<Hit>) {
        out.clear();
        for (idx, poly) in self.polygons.iter().enumerate() {
            if idx as PolygonId == ray.skip {
                continue;
            }
            if let Some((t, u, v, front)) = poly.intersect(ray.origin, ray.dir, ray.t_max) {
                out.push(Hit {
                    polygon: idx as PolygonId,
                    u,
                    v,
                    t,
                    front,
                });
            }
        }
        out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.polygon.cmp(&b.polygon)));
    }
}

/// Materials named once each, with reflectance in [0, 1) and emission finite, ≥ 0.
fn check_materials(materials: &[Material]) -> Result<(), Error> {
    let mut seen = std::collections::HashSet::new();
    for m in materials {
        if !seen.insert(m.name.as_str()) {
            return Err(Error::DuplicateMaterial {
                name: m.name.clone(),
            });
        }
        let r = m.reflectance.0;
        if !r.iter().all(|c| c.is_finite() && (0.0..1.0).contains(c)) {
            return Err(Error::Material {
                material: m.name.clone(),
                what: "reflectance",
                value: r,
                rule: "each channel must be in [0, 1)",
            });
        }
        let e = m.emission.0;
        if !e.iter().all(|c| c.is_finite() && *c >= 0.0) {
            return Err(Error::Material {
                material: m.name.clone(),
                what: "emission",
                value: e,
                rule: "each channel must be finite and >= 0",
            });
        }
    }
    Ok(())
}

/// Each polygon's [`Polygon::reach`] if it is front-only, else −∞; empty when none is
/// ([`Scene::seen`]'s table).
fn front_only_reaches(polygons: &[Polygon]) -> Vec<f32> {
    if !polygons.iter().any(Polygon::front_only) {
        return Vec::new();
    }
    let reach = |p: &Polygon| {
        if p.front_only() {
            p.reach()
        } else {
            f32::NEG_INFINITY
        }
    };
    polygons.iter().map(reach).collect()
}

/// A polygon's described vertices rounded to f32, as its polygon holds them.
pub(crate) fn rounded(vertices: &[DVec3]) -> Vec<Vec3> {
    vertices.iter().map(|v| v.as_vec3()).collect()
}

/// What a scene's polygons are measured in where it decides how to cut them (patch
/// sizes, back sides' grids): its largest coordinate, as the divided scene rows are made
/// from ([`Scene::for_rows`]), so that the decisions, made on f32 vertices, are the same
/// at any scale; 1 where that coordinate is not finite and positive (the polygons' own
/// checks name the problem). Dividing by a power of two changes no decision.
fn structure_unit(desc: &SceneDesc) -> f64 {
    let unit = largest_coordinate(desc);
    if unit.is_finite() && unit > 0.0 {
        unit
    } else {
        1.0
    }
}

/// `vertices` divided by `unit` in f64, then rounded to f32 (as the divided scene holds
/// them).
fn rounded_in(vertices: &[DVec3], unit: f64) -> Vec<Vec3> {
    vertices.iter().map(|&v| (v / unit).as_vec3()).collect()
}

/// The largest magnitude of a described coordinate (NaN where one is NaN).
impl SceneDesc {
    /// The largest magnitude of any vertex coordinate (NaN if one is): the unit rows
    /// are made in ([`Scene::for_rows`]).
    pub fn largest_coordinate(&self) -> f64 {
        largest_coordinate(self)
    }
}

fn largest_coordinate(desc: &SceneDesc) -> f64 {
    desc.polygons
        .iter()
        .flat_map(|p| &p.vertices)
        .map(|v| v.abs().max_element())
        .fold(0.0, |m, x| {
            if x.is_nan() || m.is_nan() {
                f64::NAN
            } else {
                m.max(x)
            }
        })
}

/// Whether `x` (finite, > 0) is a power of two.
fn is_power_of_two(x: f64) -> bool {
    x.is_normal() && x.to_bits() & ((1u64 << 52) - 1) == 0
}

/// Where `desc`'s largest coordinate is finite, positive and not a power of two: it,
/// and `desc` with every vertex divided by it, without what rows do not use (names,
/// groups, the camera: a large mesh's names are a good part of its description).
fn divided(desc: &SceneDesc, unit: f64) -> Option<(f64, Box<SceneDesc>)> {
    if !(unit.is_finite() && unit > 0.0) || is_power_of_two(unit) {
        return None;
    }
    let polygons = desc
        .polygons
        .iter()
        .map(|p| PolygonDesc {
            name: String::new(),
            vertices: p.vertices.iter().map(|&v| v / unit).collect(),
            group: None,
            ..*p
        })
        .collect();
    Some((
        unit,
        Box::new(SceneDesc {
            materials: desc.materials.clone(),
            polygons,
            camera: None,
        }),
    ))
}

/// `divided` with each described polygon cut as `polygons` (the scene's, the described
/// ones first) are.
fn cut_alike(mut divided: Box<SceneDesc>, polygons: &[Polygon]) -> Box<SceneDesc> {
    for (pd, p) in divided.polygons.iter_mut().zip(polygons) {
        let (nu, nv) = p.grid();
        pd.grid = PatchGrid::Cells {
            nu: u64::from(nu),
            nv: u64::from(nv),
        };
    }
    divided
}

/// The back sides of `desc`'s two-sided polygons ([`back_side`]) with the file's index
/// of their fronts, cut by `back_grids` in order where given.
fn back_sides(desc: &SceneDesc, unit: f64, back_grids: &[PatchGrid]) -> Vec<(usize, PolygonDesc)> {
    let mut backs: Vec<(usize, PolygonDesc)> = desc
        .polygons
        .iter()
        .enumerate()
        .filter(|(_, p)| p.two_sided && !p.obstruction)
        .map(|(idx, p)| (idx, back_side(p, unit)))
        .collect();
    for ((_, back), &grid) in backs.iter_mut().zip(back_grids) {
        back.grid = grid;
    }
    backs
}

/// The back side of a two-sided polygon: its vertices in reverse order (the first
/// kept), named `NAME:back`, in group `GROUP:back`, its patch grid turned to match the
/// front's cells where its texture's u runs along the front's v (as for a triangle or
/// a parallelogram, whose edge frame then swaps u and v).
fn back_side(pd: &PolygonDesc, unit: f64) -> PolygonDesc {
    let mut vertices = pd.vertices.clone();
    if vertices.len() > 1 {
        vertices[1..].reverse();
    }
    let grid = match pd.grid {
        PatchGrid::Cells { nu, nv } => {
            // Swapped where the back's u runs along the front's v (by direction, not
            // length: a square's sides are equal).
            // (Decided on the divided vertices, [`structure_unit`].)
            let sides = |v: &[DVec3]| crate::polygon::texture_sides(&rounded_in(v, unit));
            let swapped = match (sides(&pd.vertices), sides(&vertices)) {
                (Some((fu, _)), Some((bu, bv))) => {
                    let along =
                        |a: glam::DVec3, b: glam::DVec3| a.normalize().dot(b.normalize()).abs();
                    along(fu, bv) > along(fu, bu)
                }
                _ => false,
            };
            if swapped {
                PatchGrid::Cells { nu: nv, nv: nu }
            } else {
                pd.grid
            }
        }
        size => size,
    };
    PolygonDesc {
        name: format!("{}:back", pd.name),
        vertices,
        material: pd.material,
        grid,
        group: pd.group.as_ref().map(|g| format!("{g}:back")),
        obstruction: false,
        two_sided: true,
    }
}

/// The patch-grid size of a polygon description, its sides measured on its vertices
/// divided by `unit` ([`structure_unit`]).
fn grid_cells(pd: &PolygonDesc, unit: f64) -> Result<(u64, u64), PolygonProblem> {
    match pd.grid {
        PatchGrid::Cells { nu, nv } => Ok((nu, nv)),
        PatchGrid::Size(size) => {
            if !(size.is_finite() && size > 0.0) {
                return Err(PolygonProblem::BadPatchSize { size });
            }
            if pd.vertices.len() < 3 {
                return Err(PolygonProblem::TooFewVertices {
                    count: pd.vertices.len(),
                });
            }
            // The sides of the polygon's (u, v) frame (invalid vertices get one cell:
            // the polygon's own checks then name their problem).
            let Some((lu, lv)) =
                crate::polygon::texture_side_lengths(&rounded_in(&pd.vertices, unit))
            else {
                return Ok((1, 1));
            };
            // (Rounded half up, and up within a millionth of the count (at most a
            // thousandth of a cell) below a half: the f32 sides of a scene scaled by a
            // factor that is not a power of two round differently, and a side of one and
            // a half cells would otherwise be cut in one or two at different scales.)
            let cells = |l: f64| {
                let r = l / (size / unit);
                let c = (r + 0.5 + (1e-6 * r).min(1e-3)).floor();
                if c.is_finite() {
                    (c as u64).max(1)
                } else {
                    u64::MAX
                }
            };
            Ok((cells(lu), cells(lv)))
        }
    }
}

/// Refuses a scene whose patches would not fit their ids, before any patch is made (a
/// grid over the per-polygon limit is left to its polygon's own, sharper, error).
fn check_patch_count(
    desc: &SceneDesc,
    backs: &[(usize, PolygonDesc)],
    unit: f64,
) -> Result<(), Error> {
    let count = desc
        .polygons
        .iter()
        .chain(backs.iter().map(|(_, pd)| pd))
        .filter_map(|pd| grid_cells(pd, unit).ok())
        .map(|(nu, nv)| nu.saturating_mul(nv))
        .filter(|&n| n <= crate::polygon::MAX_CELLS_PER_POLYGON)
        .fold(0u64, u64::saturating_add);
    if count > MAX_PATCHES {
        return Err(Error::TooManyPatches {
            count,
            limit: MAX_PATCHES,
        });
    }
    Ok(())
}
// A scene's facets are made here, from its polygons and their neighbours, so that the
// facets themselves know nothing of scenes.
impl Facets {
    /// The facets of `scene` (made from its [`crate::EdgeNeighbours`]), with margins for
    /// guesses: twice the members' reach beyond their edges, and a hundredth of a grid
    /// cell (a member's test may still accept a point [`Located::Clear`] in another by
    /// its sharpest corner).
    pub fn of(scene: &Scene) -> Facets {
        Facets::of_scene(scene, false)
    }

    /// [`Facets::of`] with margins for exact casting: past the members' edges by as far
    /// as their tests reach at their sharpest corners (twice the reach over the sine of
    /// the half-angle), and three hundredths of a grid cell for the rounding of points
    /// seen at a slant (what a caster checks before it locates).
    pub fn exact(scene: &Scene) -> Facets {
        Facets::of_scene(scene, true)
    }

    fn of_scene(scene: &Scene, exact: bool) -> Facets {
        let mut patch_count = vec![0u32; scene.polygons().len()];
        for p in scene.patches() {
            patch_count[p.polygon as usize] += 1;
        }
        Facets::made(
            scene.polygons(),
            &patch_count,
            scene.edge_neighbours(),
            exact,
        )
    }
}
