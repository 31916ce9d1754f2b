//! Snapshots: one PNG (as displayed), one linear EXR and one JSON of metadata sharing a unique
//! timestamped stem. Each file is written atomically; if any fails, the snapshot's other files
//! are removed so no partial snapshot remains.

use crate::app::UiSettings;
use crate::film::display::{DisplayImage, ToneMap, ViewMode};
use crate::film::{Film, write_atomic, write_exr, write_png};
use crate::scene::Camera;
use crate::session::Frame;
use crate::settings::RenderSettings;
use crossbeam_channel::{Receiver, unbounded};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// Everything needed to reproduce a snapshot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SnapshotMeta {
    /// The scene's name.
    pub scene_name: String,
    /// The scene's file; `None` for the embedded scene.
    pub scene_path: Option<PathBuf>,
    /// The view.
    pub camera: Camera,
    /// Every render parameter: resolution, spp, M per batch, fractions, C/S/R, seed, direct mode.
    pub settings: RenderSettings,
    /// Photons traced so far.
    pub photons_traced: u64,
    /// Photon rays stored for re-splatting.
    pub photon_rays: usize,
    /// Batches whose light the image holds.
    pub batches: usize,
    /// Seconds of rendering.
    pub elapsed_s: f64,
    /// The view mode of the PNG.
    pub view_mode: ViewMode,
    /// The PNG's exposure, stops.
    pub exposure: f32,
    /// The PNG's tone mapping.
    pub tone_map: ToneMap,
    /// raysplat's version.
    pub program_version: String,
    /// UTC, ISO 8601.
    pub created: String,
}

impl SnapshotMeta {
    /// The metadata of `frame` shown with the display settings of `ui`, created now.
    pub fn new(frame: &Frame, ui: &UiSettings) -> Self {
        Self {
            scene_name: frame.scene_name.clone(),
            scene_path: frame.scene_path.clone(),
            camera: frame.camera.clone(),
            settings: frame.settings.clone(),
            photons_traced: frame.stats.method.photons_traced,
            photon_rays: frame.stats.method.photon_rays,
            batches: frame.stats.method.passes as usize,
            elapsed_s: frame.stats.elapsed_s,
            view_mode: ui.view_mode,
            exposure: ui.exposure,
            tone_map: ui.tone_map,
            program_version: env!("CARGO_PKG_VERSION").to_string(),
            created: utc_now().1,
        }
    }
}

/// The three files of one snapshot.
#[derive(Clone, Debug, PartialEq)]
pub struct SnapshotFiles {
    /// The image as displayed.
    pub png: PathBuf,
    /// The linear film.
    pub exr: PathBuf,
    /// The [`SnapshotMeta`].
    pub json: PathBuf,
}

/// Write a snapshot into `folder`; the stem is `raysplat-YYYYMMDD-HHMMSS-mmm` (plus `-N` when
/// that exists already).
pub fn write_snapshot(
    folder: &Path,
    shown: &DisplayImage,
    film: &Film,
    meta: &SnapshotMeta,
) -> Result<SnapshotFiles, String> {
    if !folder.is_dir() {
        return Err(format!(
            "snapshot folder {} does not exist or is not a folder",
            folder.display()
        ));
    }
    let (stem_time, _) = utc_now();
    let mut stem = format!("raysplat-{stem_time}");
    let mut k = 1;
    while ["png", "exr", "json"]
        .iter()
        .any(|e| folder.join(format!("{stem}.{e}")).exists())
    {
        k += 1;
        stem = format!("raysplat-{stem_time}-{k}");
    }
    let files = SnapshotFiles {
        png: folder.join(format!("{stem}.png")),
        exr: folder.join(format!("{stem}.exr")),
        json: folder.join(format!("{stem}.json")),
    };
    let json = serde_json::to_vec_pretty(meta).map_err(|e| e.to_string())?;
    let result = write_png(&files.png, shown.width, shown.height, &shown.rgb())
        .and_then(|_| write_exr(&files.exr, film.width, film.height, &film.rgb))
        .and_then(|_| write_atomic(&files.json, &json));
    if let Err(e) = result {
        for p in [&files.png, &files.exr, &files.json] {
            let _ = std::fs::remove_file(p);
        }
        return Err(e);
    }
    Ok(files)
}

/// [`write_snapshot`] on a helper thread; the receiver gets its result.
pub fn write_snapshot_in_background(
    folder: PathBuf,
    shown: DisplayImage,
    film: Film,
    meta: SnapshotMeta,
) -> Receiver<Result<SnapshotFiles, String>> {
    let (tx, rx) = unbounded();
    std::thread::spawn(move || {
        let _ = tx.send(write_snapshot(&folder, &shown, &film, &meta));
    });
    rx
}

/// ("YYYYMMDD-HHMMSS-mmm", "YYYY-MM-DDTHH:MM:SS.mmmZ") for now, in UTC.
pub fn utc_now() -> (String, String) {
    let d = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap_or_default();
    let secs = d.as_secs() as i64;
    let ms = d.subsec_millis();
    let (y, mo, day) = civil_from_days(secs.div_euclid(86_400));
    let s = secs.rem_euclid(86_400);
    let (h, mi, se) = (s / 3600, (s / 60) % 60, s % 60);
    (
        format!("{y:04}{mo:02}{day:02}-{h:02}{mi:02}{se:02}-{ms:03}"),
        format!("{y:04}-{mo:02}-{day:02}T{h:02}:{mi:02}:{se:02}.{ms:03}Z"),
    )
}

/// Days since 1970-01-01 to (year, month, day), proleptic Gregorian (H. Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(19_723), (2024, 1, 1));
        assert_eq!(civil_from_days(20_514), (2026, 3, 2));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
    }
}
