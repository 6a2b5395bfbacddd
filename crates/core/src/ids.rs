//! Ids and their sentinels, in one place: the values that stand in an item buffer or a
//! polygon slot for "not a patch" and "no polygon".

/// Index of a polygon in its scene.
pub type PolygonId = u32;
/// Index of a patch (one texel of a polygon's patch texture) in its scene.
pub type PatchId = u32;

/// No polygon: a ray's [`crate::Ray::skip`] when it skips none, a cell whose ray has
/// met nothing yet, a cell that sees no polygon.
pub const NO_POLYGON: PolygonId = PolygonId::MAX;

/// Item-buffer entry of a cell whose ray left the scene.
pub const ESCAPED: PatchId = PatchId::MAX;
/// Item-buffer entry of a cell whose ray met a polygon from behind (docs/design.md, "Frames and
/// conventions").
pub const BACK: PatchId = PatchId::MAX - 1;
/// Item-buffer entry of a cell of an estimate that nothing landed in, before its hole
/// is filled (never in a finished item buffer).
pub const HOLE: PatchId = PatchId::MAX - 2;
