//! raysplat: global illumination previews by photon ray splatting (Herzog et al., EG 2007).
//!
//! The crate is layered; each layer imports only the ones above it in this list
//! (docs/architecture.md has the table, and `tests/layering.rs` enforces it):
//!
//! 1. foundation: [`choice`], [`sampling`], [`pack`], [`bsdf`], [`scene`], [`film`]
//! 2. [`pipeline`]: the paper's stages (eye pass, splat tree, light pass, splatting, radiance
//!    map, directional records, cache, filter, direct light, photon maps)
//! 3. [`settings`]: every render setting and the one table of limits
//! 4. [`methods`]: rs, rc, pm, pt and final gathering behind one `Method` trait and factory
//! 5. [`session`]: the previewer's progressive worker thread
//! 6. [`app`]: the egui window, one panel per file
//!
//! The `raysplat` binary's command line (`src/cli/`) sits on top of all of them.

#![warn(missing_docs)]

pub mod app;
pub mod bsdf;
pub mod choice;
pub mod film;
pub mod methods;
pub mod pack;
pub mod pipeline;
pub mod sampling;
pub mod scene;
pub mod session;
pub mod settings;
