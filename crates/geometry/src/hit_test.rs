//! The one ray–polygon hit test, in f32, shared by every caster (the voxel grid's rays,
//! the polygon scan's spans, improved estimation's guesses, brute force), so that they
//! agree by construction, to the bit.
//!
//! A ray `o + t·dir` meets the plane `n·p = d` at `t = (d − n·o) / n·dir`, at
//! parameters `u = u(o) + t du·dir`, `v = v(o) + t dv·dir` (du, dv the dual basis of
//! the polygon's edges). Everything but the three dot products with `dir` depends on
//! the origin alone: [`OriginTerms`], made once per origin from the polygon's own
//! [`PolygonTerms`]. Dot products are glam's, term by term (`(x + y) + z`), and nothing
//! is fused, so a vectorised kernel and a scalar one give the same bits.

use crate::Polygon;
use glam::Vec3;

/// Result of a ray–polygon intersection: `(t, u, v, front)`.
pub type PolygonHit = (f32, f32, f32, bool);

/// What the hit test reads of a polygon, packed in 64 bytes: the plane (`n·p = d`),
/// the dual basis giving (u, v) (`u = p·du − du_off`), and the (u, v) bounds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct PolygonTerms {
    pub normal: Vec3,
    pub plane_d: f32,
    pub du: Vec3,
    pub du_off: f32,
    pub dv: Vec3,
    pub dv_off: f32,
    /// `[u_lo, u_hi, v_lo, v_hi]`: see [`Polygon::uv_bounds`].
    pub uv_bounds: [f32; 4],
}

/// A polygon's hit-test terms for rays from one origin `o`, packed in 64 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct OriginTerms {
    pub normal: Vec3,
    /// `d − n·o`: `t = num / n·dir`. Negative where `o` is in front of the plane.
    pub num: f32,
    pub du: Vec3,
    /// u of `o`.
    pub u0: f32,
    pub dv: Vec3,
    /// v of `o`.
    pub v0: f32,
    pub uv_bounds: [f32; 4],
}

impl PolygonTerms {
    /// The terms for rays from `o`.
    #[inline(always)]
    pub fn at(&self, o: Vec3) -> OriginTerms {
        OriginTerms {
            normal: self.normal,
            num: self.plane_d - self.normal.dot(o),
            du: self.du,
            u0: o.dot(self.du) - self.du_off,
            dv: self.dv,
            v0: o.dot(self.dv) - self.dv_off,
            uv_bounds: self.uv_bounds,
        }
    }
}

impl OriginTerms {
    /// `n·dir`: negative for a ray meeting the front (the side the normal points to).
    #[inline(always)]
    pub fn denom(&self, x: f32, y: f32, z: f32) -> f32 {
        (self.normal.x * x + self.normal.y * y) + self.normal.z * z
    }

    /// (u, v) of the point at `t` along `dir` = (x, y, z).
    #[inline(always)]
    pub fn uv(&self, t: f32, x: f32, y: f32, z: f32) -> (f32, f32) {
        (
            self.u0 + t * ((self.du.x * x + self.du.y * y) + self.du.z * z),
            self.v0 + t * ((self.dv.x * x + self.dv.y * y) + self.dv.z * z),
        )
    }

    /// Where the ray along `d` meets the plane, if at `0 < t < t_max`: (t, u, v, n·d),
    /// before any inside test.
    #[inline(always)]
    pub fn along(&self, d: Vec3, t_max: f32) -> Option<(f32, f32, f32, f32)> {
        let denom = self.denom(d.x, d.y, d.z);
        let t = self.num / denom;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        let (u, v) = self.uv(t, d.x, d.y, d.z);
        Some((t, u, v, denom))
    }

    /// These terms as a front-only polygon's ([`Polygon::front_only`]) of reach
    /// `reach`: unchanged from an origin in front of the plane by more than `reach`
    /// (`num < −reach`), and from any other no hit at all (`num` NaN, which every test
    /// refuses: `t > 0` fails). With `reach` = −∞ (not front-only) they are unchanged
    /// but for an infinite `num`, which gives no hit either way.
    #[inline(always)]
    // (Negated on purpose: a NaN `num` stays NaN.)
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn front_only(mut self, reach: f32) -> OriginTerms {
        if !(self.num < -reach) {
            self.num = f32::NAN;
        }
        self
    }

    /// Whether (u, v) lies within the (u, v) bounds (for a front-facing parallelogram,
    /// that is the whole inside test: see [`Polygon::uv_bounds`]).
    #[inline(always)]
    pub fn in_bounds(&self, u: f32, v: f32) -> bool {
        let [u_lo, u_hi, v_lo, v_hi] = self.uv_bounds;
        (u >= u_lo) & (u <= u_hi) & (v >= v_lo) & (v <= v_hi)
    }
}

impl Polygon {
    /// Intersects the ray `o + t·d`, `0 < t < t_max`, with this polygon (the shared hit
    /// test: [`Polygon::hit_from`] with [`Polygon::terms`] at `o`).
    ///
    /// On the front side, points within a few ulps of the scene's scale outside an edge
    /// count as inside, so polygons that share an edge leave no crack for a ray to slip
    /// through; on the back side the polygon shrinks instead (see [`Polygon::contains_uv_back`]).
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<PolygonHit> {
        self.hit_from(&self.terms_at(o), d, t_max)
    }

    /// Its terms for rays from `o` as every caster tests them: [`crate::PolygonTerms::at`],
    /// with no hit at all from an origin a front-only polygon does not face
    /// ([`Polygon::front_only`], [`OriginTerms::front_only`]).
    #[inline]
    pub fn terms_at(&self, o: Vec3) -> OriginTerms {
        let terms = self.terms().at(o);
        if self.front_only() {
            terms.front_only(self.reach())
        } else {
            terms
        }
    }

    /// Its hit-test terms (see the module documentation).
    #[inline]
    pub fn terms(&self) -> PolygonTerms {
        PolygonTerms {
            normal: self.normal(),
            plane_d: self.plane_offset(),
            du: self.dual_basis().0,
            du_off: self.origin().dot(self.dual_basis().0),
            dv: self.dual_basis().1,
            dv_off: self.origin().dot(self.dual_basis().1),
            uv_bounds: self.uv_bounds(),
        }
    }

    /// Whether a hit at (u, v) counts: on the front (`denom < 0`), inside within the
    /// tolerance ([`Polygon::contains_uv`]; a parallelogram already known to be within
    /// its bounds passes with `bounded`); on the back, inside the shrunk polygon
    /// ([`Polygon::contains_uv_back`]).
    #[inline(always)]
    pub fn accepts(&self, denom: f32, bounded: bool, u: f32, v: f32) -> bool {
        if denom < 0.0 {
            bounded || self.contains_uv(u, v)
        } else {
            self.contains_uv_back(u, v)
        }
    }

    /// The hit of the ray `o + t·d`, `0 < t < t_max`, given this polygon's terms for
    /// `o`: (t, u, v, front).
    #[inline]
    pub fn hit_from(&self, h: &OriginTerms, d: Vec3, t_max: f32) -> Option<PolygonHit> {
        let (t, u, v, denom) = h.along(d, t_max)?;
        self.accepts(denom, false, u, v)
            .then_some((t, u, v, denom < 0.0))
    }
}

/// What the inside test of a polygon needs to be vectorised, read once (so that a
/// kernel need not reach into the polygon).
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// Inside its (u, v) bounds alone, from the front.
    Parallelogram,
    /// Its three edge functions decide (the very sums of [`Polygon::contains_uv`] and
    /// [`Polygon::contains_uv_back`]).
    Triangle(Triangle),
    /// Its own inside test, cell by cell.
    Other,
}

impl Shape {
    /// [`Polygon::hit_from`] of the polygon of this shape (its terms for the ray's
    /// origin `h`), reading the polygon (through `poly`) only where the shape alone
    /// does not decide: the same answer, to the bit.
    #[inline]
    pub fn hit_from<'p>(
        &self,
        poly: impl FnOnce() -> &'p Polygon,
        h: &OriginTerms,
        d: Vec3,
        t_max: f32,
    ) -> Option<PolygonHit> {
        let (t, u, v, denom) = h.along(d, t_max)?;
        self.accepts(poly, h, denom, u, v)
            .then_some((t, u, v, denom < 0.0))
    }

    /// [`Polygon::accepts`] (not from behind) of the polygon of this shape at (u, v),
    /// met with `denom` (its terms `h`), reading the polygon only where the shape alone
    /// does not decide: the same answer, to the bit.
    #[inline]
    pub fn accepts<'p>(
        &self,
        poly: impl FnOnce() -> &'p Polygon,
        h: &OriginTerms,
        denom: f32,
        u: f32,
        v: f32,
    ) -> bool {
        match self {
            // `contains_uv` of a parallelogram is its (u, v) bounds, the very f32 sums.
            Shape::Parallelogram if denom < 0.0 => h.in_bounds(u, v),
            Shape::Triangle(tri) => {
                let limit = if denom < 0.0 { -tri.eps } else { tri.eps };
                tri.edges
                    .iter()
                    .all(|e| e[0] * u + e[1] * v + e[2] >= limit)
            }
            _ => poly().accepts(denom, false, u, v),
        }
    }

    pub fn of(poly: &Polygon) -> Shape {
        match poly.edge_functions() {
            _ if poly.is_parallelogram() => Shape::Parallelogram,
            [a, b, c] => Shape::Triangle(Triangle {
                edges: [*a, *b, *c],
                eps: poly.edge_tolerance(),
            }),
            _ => Shape::Other,
        }
    }
}

/// A triangle's edge functions and tolerance ([`Polygon::edge_functions`],
/// [`Polygon::edge_tolerance`]).
#[derive(Clone, Copy, Debug)]
pub struct Triangle {
    pub edges: [[f32; 3]; 3],
    pub eps: f32,
}
