//! How much memory a render will need, estimated from its settings before anything is
//! allocated, so that an image size or sample count that cannot fit is refused with one line
//! instead of aborting the process.

use crate::film::estimate;
use crate::methods::MethodError;
use crate::pipeline::eye::EYE_SAMPLE_BYTES;
use crate::pipeline::photon::PhotonRay;
use crate::pipeline::splat_tree::DomainCache;
use crate::settings::{MethodKind, RenderSettings};

/// Bytes per pixel of the film (rgb and the AOVs), the radiance map and the displayed image.
const PER_PIXEL: u64 = 256;
/// Bytes per eye sample: the sample (SoA), its splat target, tree share and accumulators.
/// Glossy samples' directional records (up to 48 floats) are counted for every sample, an
/// upper bound for scenes full of glossy surfaces.
const PER_EYE_SAMPLE: u64 = EYE_SAMPLE_BYTES as u64 + 32 + 16 + 2 * 28 + 48 * 4;
/// Per pixel for glossy lobes traced by the eye path (docs/deviations.md §38): the film's glossy-source AOV
/// (8 bytes) and rs's per-batch lobe sums (24); the eye samples its lobe paths reach (one per
/// second eye sample, `eye::trace_lobes`) are counted with the eye samples.
const TRACED_LOBES_PER_PIXEL: u64 = 8 + 24;
/// Per pixel for the traced lobes' sums at h and h/k when the error is estimated (§51).
const TRACED_LOBES_ESTIMATE_PER_PIXEL: u64 = 24;
/// Per pixel for rs's finished eye passes (docs/deviations.md §41): rgb, direct and indirect
/// sums; and the current pass's sum of NEE draws beside its emission (§50).
const EARLIER_PASSES_PER_PIXEL: u64 = 3 * 12 + 12;
/// Bytes per photon ray of a batch for the count of where the rays landed (an upper end of
/// what was measured).
const PHOTON_DENSITY_PER_RAY: u64 = 16;
/// Gather hits a final-gathering band holds at once (`fg::FgSettings::max_band_samples`) and
/// their bytes each.
const FG_BAND_BYTES: u64 = (1 << 17) * (EYE_SAMPLE_BYTES as u64 + 32 + 16 + 28);

/// The estimated peak bytes of a render with `settings` (one batch of photons in flight and
/// one stored; the previewer's ray budget adds its own, bounded, store).
pub fn estimate_bytes(settings: &RenderSettings) -> u64 {
    let pixels = settings.width as u64 * settings.height as u64;
    let film = pixels.saturating_mul(PER_PIXEL);
    let eye = pixels
        .saturating_mul(settings.spp as u64)
        .saturating_mul(PER_EYE_SAMPLE);
    // Two batches' rays with their φ (docs/deviations.md §63), and the count of where they
    // landed: measured 2.6 (CORNELL BOX I) to 12 (SIBENIK) bytes per ray over three batches
    // of 200,000; it grows with the lit surface, not with time.
    let photons = settings.photons.saturating_mul(
        2 * (std::mem::size_of::<PhotonRay>() + std::mem::size_of::<f32>()) as u64
            + PHOTON_DENSITY_PER_RAY,
    );
    // The visible domains kept across eye passes, a pixel's first target each.
    let domains = if settings.splat_visibility {
        pixels.saturating_mul(DomainCache::BYTES_PER_PIXEL as u64)
    } else {
        0
    };
    match settings.method {
        MethodKind::Pt => film,
        MethodKind::RsFg | MethodKind::PmFg => film
            .saturating_add(eye)
            .saturating_add(photons)
            .saturating_add(FG_BAND_BYTES),
        // rs draws a lobe path for every second eye sample per batch (at least one per pixel
        // with a traced lobe); rc and pm trace one per eye sample in the eye pass, each
        // reaching one more eye sample (an upper bound for scenes whose every surface is too
        // glossy for the map).
        MethodKind::Rs => {
            film.saturating_add(eye)
                .saturating_add(photons)
                .saturating_add(domains)
                .saturating_add(pixels.saturating_mul(
                    TRACED_LOBES_PER_PIXEL + EARLIER_PASSES_PER_PIXEL + PER_EYE_SAMPLE,
                ))
                .saturating_add(if settings.estimate_error {
                    pixels.saturating_mul(
                        TRACED_LOBES_ESTIMATE_PER_PIXEL + estimate::BYTES_PER_PIXEL as u64,
                    )
                } else {
                    0
                })
                .saturating_add(eye / 2)
        }
        // Their one eye pass keeps no domains (in the window, a moved view keeps its last
        // view's: 44 bytes a pixel, not counted here).
        MethodKind::Rc | MethodKind::Pm => film
            .saturating_add(eye.saturating_mul(2))
            .saturating_add(photons),
    }
}

/// Bytes this machine can still give (Linux MemAvailable), if known.
pub fn available_bytes() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kb: u64 = info
        .lines()
        .find(|l| l.starts_with("MemAvailable:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(kb * 1024)
}

/// An error with the estimate when a render with `settings` would not fit in `available`
/// bytes.
pub fn check(settings: &RenderSettings, available: Option<u64>) -> Result<(), MethodError> {
    let needed = estimate_bytes(settings);
    match available {
        Some(available) if needed > available => Err(MethodError::TooLarge {
            needed,
            available,
            width: settings.width,
            height: settings.height,
            spp: settings.spp,
            photons: settings.photons,
        }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_render_fits_and_a_huge_one_does_not() {
        let s = RenderSettings::default();
        // 500×500×4 and 200k photons: tens of MB, as measured (docs/benchmarks.md).
        let mb = estimate_bytes(&s) as f64 / 1e6;
        assert!((50.0..1000.0).contains(&mb), "{mb} MB");
        assert!(check(&s, Some(8 << 30)).is_ok());
        let huge = RenderSettings {
            width: 4096,
            height: 4096,
            spp: 64,
            ..s
        };
        let e = check(&huge, Some(8 << 30)).unwrap_err().to_string();
        assert!(
            e.contains("4096×4096") && e.contains("8.0 GiB are available"),
            "{e}"
        );
        assert!(check(&huge, None).is_ok(), "unknown memory is not refused");
    }
}
