//! The caster interface: whatever makes a patch's exact item buffer, and casts the
//! odd single rays that estimation and boundary lists need, plugs in here.
//!
//! Every [`RayCast`] (the voxel grid, brute force, any later accelerator) is a
//! [`Caster`], one ray a cell ([`Hemisphere::cast`]); [`Scan`] is the polygon scan
//! ([`Hemisphere::scan`]), which needs no accelerator. All give the same item buffers
//! and the same hits, to the bit: the same f32 test of each (ray, polygon) pair, the
//! same culling and the same tie rule (the lower polygon id).

use crate::item_buffer::{ItemBuffer, Viewpoint};
use crate::{Hemisphere, ScanScratch};
use rad_core::{Hit, PatchId, PolygonId, Ray, RayCast, Vec3};
use rad_geometry::Scene;

/// Fills exact item buffers of one scene's hemispheres, with per-thread scratch.
///
/// The scene passed to each call must be the one the caster was made for (a voxel
/// grid is built for one scene; the scan reads the scene it is given).
pub trait Caster: Sync {
    /// Per-thread working memory; make one per thread with [`Caster::scratch`].
    type Scratch: Send;

    fn scratch(&self) -> Self::Scratch;

    /// The exact item buffer of `patch`'s hemisphere `hemi` (from its centre), into
    /// `buf`.
    fn item_buffer(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        patch: PatchId,
        scratch: &mut Self::Scratch,
        buf: &mut ItemBuffer,
    ) {
        self.item_buffer_at(scene, hemi, Viewpoint::of_patch(scene, patch), scratch, buf)
    }

    /// The exact item buffer of the hemisphere `hemi` at any point of a polygon (in
    /// its frame), into `buf`: [`Caster::item_buffer`] is this at a patch's centre.
    fn item_buffer_at(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        at: Viewpoint,
        scratch: &mut Self::Scratch,
        buf: &mut ItemBuffer,
    );

    /// The closest hit of each ray `origin + t·dirs[k]` (unit directions, never hitting
    /// `skip`), into `out[k]` after clearing `out`: [`RayCast::closest_hits_from`]'s
    /// answers (improved estimation's real rays).
    fn closest_hits(
        &self,
        scene: &Scene,
        origin: Vec3,
        skip: PolygonId,
        dirs: &[Vec3],
        scratch: &mut Self::Scratch,
        out: &mut Vec<Option<Hit>>,
    );

    /// Every polygon `ray` crosses, sorted by `t` (ties by id): [`RayCast::all_hits`]'s
    /// answer (boundary lists).
    fn all_hits_along(
        &self,
        scene: &Scene,
        ray: &Ray,
        scratch: &mut Self::Scratch,
        out: &mut Vec<Hit>,
    );
}

/// A ray caster is a caster: one ray a cell.
impl<R: RayCast> Caster for R {
    type Scratch = R::Scratch;

    fn scratch(&self) -> R::Scratch {
        self.new_scratch()
    }

    fn item_buffer_at(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        at: Viewpoint,
        scratch: &mut R::Scratch,
        buf: &mut ItemBuffer,
    ) {
        hemi.cast_at(scene, self, at, scratch, buf)
    }

    fn closest_hits(
        &self,
        _: &Scene,
        origin: Vec3,
        skip: PolygonId,
        dirs: &[Vec3],
        scratch: &mut R::Scratch,
        out: &mut Vec<Option<Hit>>,
    ) {
        self.closest_hits_from(origin, skip, dirs, scratch, out)
    }

    fn all_hits_along(&self, _: &Scene, ray: &Ray, scratch: &mut R::Scratch, out: &mut Vec<Hit>) {
        self.all_hits(ray, scratch, out)
    }
}

/// The polygon scan ([`Hemisphere::scan`]): each polygon tested on the cells of its
/// angular box. Its single rays test every polygon, with the scan's kernel (closest
/// hits) or [`rad_geometry::Polygon::intersect`] (all hits): brute force, which is
/// what the voxel grid is checked against.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Scan;

impl Caster for Scan {
    type Scratch = ScanScratch;

    fn scratch(&self) -> ScanScratch {
        ScanScratch::default()
    }

    fn item_buffer_at(
        &self,
        scene: &Scene,
        hemi: &Hemisphere,
        at: Viewpoint,
        scratch: &mut ScanScratch,
        buf: &mut ItemBuffer,
    ) {
        hemi.scan_at(scene, at, scratch, buf)
    }

    fn closest_hits(
        &self,
        scene: &Scene,
        origin: Vec3,
        skip: PolygonId,
        dirs: &[Vec3],
        scratch: &mut ScanScratch,
        out: &mut Vec<Option<Hit>>,
    ) {
        out.clear();
        let polygons = scene.polygons();
        let own = polygons.get(skip as usize).map(|p| p.normal());
        // The grid's culling: with every ray leaving the plane of `skip` forwards, a
        // polygon wholly behind it is never tested.
        let cull = own.filter(|&n| dirs.iter().all(|d| d.dot(n) > 0.0));
        let (o, hits) = (origin.as_dvec3(), &mut scratch.rays);
        hits.begin_rays(dirs);
        for (id, poly) in polygons.iter().enumerate() {
            if id == skip as usize || cull.is_some_and(|n| poly.wholly_behind(o, n.as_dvec3())) {
                continue;
            }
            hits.test(poly, id as PolygonId, &poly.terms_at(origin), 0..dirs.len());
        }
        hits.hits_into(polygons, dirs, out);
    }

    fn all_hits_along(&self, scene: &Scene, ray: &Ray, _: &mut ScanScratch, out: &mut Vec<Hit>) {
        scene.all_hits(ray, out)
    }
}
