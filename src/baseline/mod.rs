//! Comparison methods sharing the core's scene, eye pass and light pass: an unbiased path
//! tracer (the reference everyone compares against) and photon mapping with K-NN density
//! estimation (Jensen), plus the per-pixel error maps `compare` writes.

pub mod compare;
pub mod final_gather;
pub mod photon_map;
pub mod pt;

use serde::{Deserialize, Serialize};

/// Rendering methods.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Photon ray splatting (the paper).
    Rs,
    /// Ray splatting with radiance caching (§8.3): photon rays are splatted onto sparse cache
    /// records only, which are interpolated in image space.
    Rc,
    /// Photon mapping with K-NN density estimation, visualised directly (Jensen).
    Pm,
    /// Unbiased path tracing with next-event estimation and MIS.
    Pt,
    /// Ray splatting with final gathering (§8.4).
    RsFg,
    /// Photon mapping with final gathering.
    PmFg,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Rs => "rs",
            Method::Rc => "rc",
            Method::Pm => "pm",
            Method::Pt => "pt",
            Method::RsFg => "rs-fg",
            Method::PmFg => "pm-fg",
        }
    }
}
