//! Module meshing.
