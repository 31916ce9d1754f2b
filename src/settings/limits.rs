//! The one table of accepted ranges: the window's sliders, the worker's clamps, the command
//! line's value parsers and [`super::RenderSettings::validate`] all read it.

use super::Limit;
use crate::scene::environment::{ANGLE_RANGE, STRENGTH_RANGE};

/// Environment (and sun) strength, a multiplier of radiance.
pub const ENV_STRENGTH: Limit<f32> = Limit {
    min: *STRENGTH_RANGE.start(),
    max: *STRENGTH_RANGE.end(),
};
/// Environment rotation about +Y, degrees.
pub const ENV_ROTATION: Limit<f32> = Limit {
    min: *ANGLE_RANGE.start(),
    max: *ANGLE_RANGE.end(),
};

/// Image width and height, pixels.
pub const RESOLUTION: Limit<u32> = Limit { min: 8, max: 4096 };
/// Eye samples per pixel.
pub const SPP: Limit<u32> = Limit { min: 1, max: 64 };
/// Paths per pixel of a fixed-budget path-traced image.
pub const PT_SPP: Limit<u32> = Limit {
    min: 1,
    max: 1 << 20,
};
/// M, stored photon rays per batch.
pub const PHOTONS: Limit<u64> = Limit {
    min: 100,
    max: 100_000_000,
};
/// C, eq. 8's smoothness.
pub const SMOOTHNESS_C: Limit<f32> = Limit {
    min: 0.05,
    max: 5.0,
};
/// S, eq. 8's sensitivity.
pub const SENSITIVITY_S: Limit<f32> = Limit {
    min: 0.01,
    max: 1.0,
};
/// R, the bandwidth range: every h within [R·h̄, h̄/R].
pub const MAX_BANDWIDTH_R: Limit<f32> = Limit {
    min: 0.01,
    max: 1.0,
};
/// K of the floor from the photons stored (docs/deviations.md §63): 0 is off.
pub const FLOOR_NEIGHBOURS: Limit<f32> = Limit {
    min: 0.0,
    max: 256.0,
};
/// Longest specular chain.
pub const SPECULAR_DEPTH: Limit<u32> = Limit { min: 0, max: 64 };
/// Light samples per eye sample (NEE).
pub const NEE_SAMPLES: Limit<u32> = Limit { min: 1, max: 256 };
/// The window's Light samples slider, within [`NEE_SAMPLES`]: at 256 an eye pass at 500×500
/// took 10–12 s in a new user's trial, and a camera move or Restart waits for the pass under
/// way.
pub const WINDOW_NEE_SAMPLES: Limit<u32> = Limit { min: 1, max: 32 };
/// K of the photon maps.
pub const PM_K: Limit<usize> = Limit {
    min: 1,
    max: 100_000,
};
/// Gather rays per eye sample (final gathering).
pub const FG_RAYS: Limit<u32> = Limit { min: 1, max: 4096 };
/// ε, the radiance cache's error.
pub const CACHE_ERROR: Limit<f32> = Limit {
    min: 0.05,
    max: 2.0,
};
/// Cache records covering every pixel.
pub const MIN_RECORDS: Limit<u32> = Limit { min: 1, max: 16 };
/// Scale of the image-space filter's radius.
pub const FILTER_STRENGTH: Limit<f32> = Limit { min: 0.0, max: 4.0 };
/// Photon rays kept for re-splatting in the window.
pub const RAY_BUDGET: Limit<usize> = Limit {
    min: 50_000,
    max: 100_000_000,
};
/// Wall-clock budget of a headless render, seconds.
pub const TIME_BUDGET: Limit<f64> = Limit {
    min: 0.001,
    max: 1e6,
};
/// Batches (or passes) of a headless render with `--batches`.
pub const BATCHES: Limit<u64> = Limit {
    min: 1,
    max: 1_000_000,
};
/// Emitted photons per stored photon after which a class stops filling (dark or closed
/// scenes would otherwise emit for ever).
pub const MAX_EMITTED_FACTOR: Limit<u64> = Limit { min: 1, max: 1000 };
/// Worker threads.
pub const THREADS: Limit<usize> = Limit { min: 1, max: 1024 };
/// Repetitions of a benchmark row.
pub const RUNS: Limit<u32> = Limit { min: 1, max: 1000 };
/// Display exposure, stops.
pub const EXPOSURE: Limit<f32> = Limit {
    min: -16.0,
    max: 16.0,
};
