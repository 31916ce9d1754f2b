//! `bench --quality-references DIR`: quality over time (docs/benchmarks.md, "Quality over
//! time"). The session worker is driven
//! exactly as the window drives it (its default settings: 500×500, one eye sample per pixel,
//! 20,000 photons per batch), and the relMSE of the newest full-size frame against a long
//! path-traced reference is read after 1, 2, 5, 10 and 30 s of wall time; the same for the
//! window's path-traced reference view mode. One row per scene and method, and a log-log plot
//! of both curves (a PNG drawn with `plotters`).

use glam::Vec3;
use plotters::prelude::*;
use raysplat::scene::{BuiltinScene, Scene};
use raysplat::session::{Command, Frame, Session, SessionConfig};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The seed of the curves' sessions; references are made with the default seed (1).
pub const SEED: u64 = 7;

/// The checkpoints, in seconds of wall time since the session was started.
pub const CHECKPOINTS: [f64; 5] = [1.0, 2.0, 5.0, 10.0, 30.0];

/// The scenes of the rows: file stem of the reference in DIR, and the built-in scene.
pub const SCENES: [(&str, BuiltinScene); 3] = [
    ("classic", BuiltinScene::CornellClassic),
    ("cornell1", BuiltinScene::CornellBox1),
    ("cornell2", BuiltinScene::CornellBox2),
];

/// What the window shows: the photon-splatted image, or the path-traced reference view.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Shown {
    /// rs with the window's batches.
    Splatted,
    /// The reference view mode (`pt`, one path per pixel per step).
    PathTraced,
}

impl Shown {
    fn name(self) -> &'static str {
        match self {
            Shown::Splatted => "window",
            Shown::PathTraced => "pt_view",
        }
    }
}

/// One curve: relMSE at each checkpoint reached (`None` where no full-size frame had arrived).
pub struct Curve {
    pub scene: &'static str,
    pub shown: Shown,
    pub rel_mse: Vec<Option<f64>>,
}

/// The reference of scene `stem` in `dir`, `DIR/<stem>.exr`; the error says how to make a
/// missing one (`bench` reads it and checks its size with the other rows' references).
pub fn reference_path(dir: &Path, stem: &str) -> Result<PathBuf, String> {
    let path = dir.join(format!("{stem}.exr"));
    if path.is_file() {
        return Ok(path);
    }
    let size = SessionConfig::default().settings;
    Err(format!(
        "{}: missing; make it with `raysplat render builtin:{stem} --method pt --spp 1024 \
         --width {} --height {} --out {}`",
        path.display(),
        size.width,
        size.height,
        path.display()
    ))
}

/// The window's defaults a bench row may turn off to compare with what they replaced.
#[derive(Clone, Copy, Debug)]
pub struct Window {
    /// Eye passes drawn anew as batches go on (docs/deviations.md §41).
    pub progressive_eye: bool,
    /// C chosen by the render (the window's Auto box, §51); off: Table 2's C.
    pub auto_c: bool,
}

impl Window {
    /// Turn off in `config` what this variant turns off.
    pub fn apply(&self, config: &mut SessionConfig) {
        config.settings.progressive_eye &= self.progressive_eye;
        if !self.auto_c {
            config.settings.auto_c = false;
            config.settings.estimate_error = false;
        }
    }
}

/// Run every curve for `seconds` (checkpoints beyond it are dropped), print one line each.
pub fn run_curves(references: &[Vec<Vec3>], seconds: f64, window: Window) -> Vec<Curve> {
    let mut curves = Vec::new();
    for ((stem, which), reference) in SCENES.iter().zip(references) {
        let scene = Arc::new(Scene::builtin(*which));
        for shown in [Shown::Splatted, Shown::PathTraced] {
            let rel_mse = curve(scene.clone(), shown, reference, seconds, window);
            let cells: Vec<String> = rel_mse
                .iter()
                .map(|e| e.map_or("—".into(), |e| format!("{e:.4}")))
                .collect();
            println!(
                "quality_{stem}_{:<8} relMSE at {:?} s: {}",
                shown.name(),
                &CHECKPOINTS[..rel_mse.len()],
                cells.join(" ")
            );
            curves.push(Curve {
                scene: stem,
                shown,
                rel_mse,
            });
        }
    }
    curves
}

/// One session from its start: the newest full-size frame's relMSE at each checkpoint.
fn curve(
    scene: Arc<Scene>,
    shown: Shown,
    reference: &[Vec3],
    seconds: f64,
    window: Window,
) -> Vec<Option<f64>> {
    let mut config = SessionConfig::default();
    window.apply(&mut config);
    // Not the references' seed: the path tracer's streams depend on seed, pixel and sample
    // only, so with the same seed the path-traced view would replay the reference's own first
    // paths and its error would come out too small.
    config.settings.seed = SEED;
    let start = Instant::now();
    let session = Session::spawn(scene, None, config, None);
    if shown == Shown::PathTraced {
        session.send(Command::SetReference(true));
    }
    let checkpoints: Vec<f64> = CHECKPOINTS
        .iter()
        .copied()
        .filter(|&t| t <= seconds)
        .collect();
    let mut out = Vec::with_capacity(checkpoints.len());
    let mut latest: Option<Frame> = None;
    for &t in &checkpoints {
        loop {
            let left = t - start.elapsed().as_secs_f64();
            if left <= 0.0 {
                break;
            }
            if let Some(f) = session.wait_frame(Duration::from_secs_f64(left.min(0.05))) {
                latest = Some(f);
            }
        }
        let image = latest.as_ref().and_then(|f| match shown {
            Shown::Splatted => Some(&f.film),
            Shown::PathTraced => f.reference.as_ref(),
        });
        out.push(
            image
                .filter(|film| film.rgb.len() == reference.len())
                .map(|film| raysplat::film::rel_mse(&film.rgb, reference)),
        );
    }
    session.send(Command::Shutdown);
    out
}

/// The rows for the JSON file: `quality_<scene>_<window|pt_view>` with the checkpoints and the
/// relMSE at each (null where none).
pub fn rows(curves: &[Curve]) -> Vec<(String, serde_json::Value)> {
    curves
        .iter()
        .map(|c| {
            (
                format!("quality_{}_{}", c.scene, c.shown.name()),
                json!({
                    "seconds": &CHECKPOINTS[..c.rel_mse.len()],
                    "rel_mse": c.rel_mse,
                }),
            )
        })
        .collect()
}

/// Plot the curves, relMSE against wall time on log-log axes: one colour per scene, the
/// window's image solid, the path-traced view dashed. Written as PNG by the `image` crate.
pub fn plot(curves: &[Curve], path: &Path) -> Result<(), String> {
    const SIZE: (u32, u32) = (900, 560);
    register_font()?;
    let err = |e: &dyn std::fmt::Display| format!("{}: plot: {e}", path.display());
    let values: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.rel_mse.iter().flatten().copied())
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    // No image reached a checkpoint (a slow machine, a short curve): the axes alone, so that
    // the plot asked for is still written and says so by its emptiness.
    let (lo, hi) = if values.is_empty() {
        (1e-4, 1.0)
    } else {
        (
            values.iter().copied().fold(f64::INFINITY, f64::min) * 0.8,
            values.iter().copied().fold(0.0, f64::max) * 1.25,
        )
    };
    let t_max = curves
        .iter()
        .map(|c| CHECKPOINTS[c.rel_mse.len().max(1) - 1])
        .fold(1.0, f64::max);
    let mut buf = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "relMSE over wall time: the window (solid) and the path-traced view (dashed)",
                ("sans-serif", 20),
            )
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d((0.9..t_max * 1.1).log_scale(), (lo..hi).log_scale())
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("wall time since start (s)")
            .y_desc("relMSE against the path-traced reference")
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .x_label_formatter(&|v| format!("{v}"))
            .draw()
            .map_err(|e| err(&e))?;
        let colours = [
            RGBColor(200, 60, 40),
            RGBColor(40, 110, 200),
            RGBColor(40, 150, 70),
        ];
        for c in curves {
            let k = SCENES.iter().position(|(s, _)| *s == c.scene).unwrap_or(0);
            let style = colours[k % colours.len()].stroke_width(2);
            let points: Vec<(f64, f64)> = CHECKPOINTS
                .iter()
                .zip(&c.rel_mse)
                .filter_map(|(&t, e)| e.map(|e| (t, e)))
                .collect();
            let label = format!("{} {}", c.scene, c.shown.name());
            let series = match c.shown {
                Shown::Splatted => chart.draw_series(LineSeries::new(points, style)),
                Shown::PathTraced => chart.draw_series(DashedLineSeries::new(points, 8, 5, style)),
            }
            .map_err(|e| err(&e))?;
            let shown = c.shown;
            series.label(label).legend(move |(x, y)| {
                let end = if shown == Shown::Splatted { 24 } else { 12 };
                PathElement::new(vec![(x, y), (x + end, y)], style)
            });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::LowerLeft)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, buf)
        .ok_or_else(|| format!("{}: plot buffer has the wrong size", path.display()))?;
    let mut png = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| err(&e))?;
    raysplat::film::write_atomic(path, &png)?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// plotters draws text with `ab_glyph` from a font we give it: egui's own sans-serif, so that
/// no system font is needed.
fn register_font() -> Result<(), String> {
    let fonts = egui::FontDefinitions::default();
    let data = fonts
        .font_data
        .get("Ubuntu-Light")
        .or_else(|| fonts.font_data.values().next())
        .ok_or("egui has no font to plot with")?;
    static FONT: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    let bytes: &'static [u8] = FONT.get_or_init(|| (*data.font).as_ref().to_vec());
    plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
        .map_err(|_| "the plot font cannot be read".to_string())
}
