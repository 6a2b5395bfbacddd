//! Exact view factors between two polygons that see each other whole: the double
//! contour integral of Stokes' theorem (Mitalas and Stephenson's form, as NIST View3D
//! and pyviewfactor compute it), each pair of edges' inner integral in closed form,
//! the outer one by adaptive Gauss-Kronrod quadrature, collinear edges (polygons that
//! share an edge) in closed form; and the clipping of a polygon to the half-space the
//! other faces. It knows no scene and no obstruction: the caller says which pairs no
//! polygon can come between.
//!
//! - `contour`: [`area_factor`], `A_1 F_12` with an estimate of its error.
//! - `clip`: [`clip_to_front`], the part of a polygon in front of a plane.
//! - `shaft`: [`Shaft`], whether a third polygon may come between two (conservative).

mod clip;
mod contour;
mod shaft;

pub use clip::clip_to_front;
pub use contour::{area_factor, view_factor, AreaFactor};
pub use shaft::Shaft;
