//! The paper's pipeline, one module per stage. Nothing here knows which method runs it.
//!
//! | stage | module | paper |
//! |---|---|---|
//! | eye pass: eye samples and splat targets, specular chains | [`eye`] | §4, §7 |
//! | kd-tree over splat targets, conical traversal | [`splat_tree`] | §7.1, Alg. 1 |
//! | light pass, pilot, eq. 7's path density, eq. 8's bandwidth | [`photon`] | §5, §6 |
//! | kernel, feasibility, 8-lane accumulation | [`splat`] | §5, §7.2 |
//! | accumulators and the per-pixel radiance map | [`radiance_map`] | §4, eq. 5 |
//! | directional bases: SH and strata | [`directional`] | §8.1 |
//! | radiance cache | [`cache`] | §8.3 |
//! | image-space filter | [`filter`] | §8.2 |
//! | explicit direct light at eye samples (NEE with MIS) | [`direct`] | — (docs/deviations.md) |
//! | K-NN photon maps (the pm baselines' density estimate) | [`photon_map`] | §9 (Jensen) |

pub mod cache;
pub mod direct;
pub mod directional;
pub mod eye;
pub mod filter;
pub mod photon;
pub mod photon_map;
pub mod radiance_map;
pub mod splat;
pub mod splat_tree;

/// A flag the caller raises when it no longer wants the work under way (the window's worker,
/// when a new view arrives: docs/benchmarks.md, "The previewer"); None: never stopped. The
/// eye pass looks at it between bands of rows, the visible domains' probes between chunks.
pub type Stop<'a> = Option<&'a std::sync::atomic::AtomicBool>;

/// `stop` is raised.
#[inline]
pub fn stopped(stop: Stop) -> bool {
    stop.is_some_and(|s| s.load(std::sync::atomic::Ordering::Acquire))
}
