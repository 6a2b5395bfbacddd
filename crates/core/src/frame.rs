//! Orthonormal local frames: `(t, b, n)` with `n` the normal, `t` the first edge direction.

use glam::Vec3;

/// A right-handed orthonormal frame `(t, b, n)`: `b = n × t`.
///
/// The hemisphere frame of a patch has +z along `n` and +x along `t`, the direction of
/// its polygon's first edge (docs/design.md, "Frames and conventions").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Frame with normal `n` and first axis along `edge` projected into the plane of `n`.
    ///
    /// # Panics
    /// In debug builds, if `n` is not unit length or `edge` is parallel to `n`.
    pub fn from_normal_edge(n: Vec3, edge: Vec3) -> Frame {
        debug_assert!((n.length() - 1.0).abs() < 1e-4, "normal must be unit");
        let t = (edge - n * n.dot(edge)).normalize();
        debug_assert!(t.is_finite(), "edge parallel to normal");
        let b = n.cross(t);
        Frame { t, b, n }
    }

    /// `world_from_local`: a direction in local coordinates (x along `t`, z along `n`).
    #[inline]
    pub fn world_from_local(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }

    /// `local_from_world`: the inverse of [`Frame::world_from_local`].
    #[inline]
    pub fn local_from_world(&self, v: Vec3) -> Vec3 {
        Vec3::new(self.t.dot(v), self.b.dot(v), self.n.dot(v))
    }
}
