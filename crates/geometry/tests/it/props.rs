//! Property tests of patch textures.
