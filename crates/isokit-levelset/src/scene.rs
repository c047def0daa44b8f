//! Module scene.
