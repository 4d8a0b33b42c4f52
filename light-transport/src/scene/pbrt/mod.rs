//! pbrt-v3 scene-format loader (in progress).
