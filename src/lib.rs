//! raysplat: global illumination previews by photon ray splatting (Herzog et al., EG 2007).
//!
//! The pipeline, one module per stage (see `DESIGN.md` in the shared folder for the map):
//! `scene` → `eye` (eye samples) → `splat_tree` (kd-tree, §7.1) ; `photon` (light pass, eq. 7,
//! eq. 8) → `splat` (Alg. 1, kernel §5) → `radiance_map` → film (`render`, `film`), with
//! explicit direct light in `direct`.

pub mod app;
pub mod baseline;
pub mod bsdf;
pub mod cache;
pub mod direct;
pub mod directional;
pub mod eye;
pub mod film;
pub mod filter;
pub mod photon;
pub mod radiance_map;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod session;
pub mod splat;
pub mod splat_tree;
