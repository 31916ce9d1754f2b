//! Command-line entry points, one file per command: `view` (the default: the interactive
//! previewer), `render`, `compare`, `bench` (with `quality`, its quality-over-time rows),
//! `tonemap`, `scenes`. The argument groups that `render` and `compare` share live in [`args`],
//! output formats and their checks in `output`; this file holds the command enum and the
//! helpers every command uses.

mod args;
mod bench;
mod compare;
mod error;
mod output;
mod quality;
mod render;
mod scenes;
mod tonemap;
mod view;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use error::CliError;
use raysplat::choice::Choice;
use raysplat::scene::{BuiltinScene, Scene};
use raysplat::settings::Limit;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

#[derive(Parser)]
#[command(
    name = "raysplat",
    version,
    about = "Global illumination previews by photon ray splatting",
    args_conflicts_with_subcommands = true,
    after_help = "`raysplat SCENE` opens the previewer on SCENE (as `raysplat view SCENE`)."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    view: view::ViewArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Open the interactive previewer (the default when no command is given).
    View(view::ViewArgs),
    /// Render a scene headless to an image (EXR, PNG or JPEG, from the extension).
    Render(args::RenderArgs),
    /// Reproduce Table 2's CORNELL BOX I row and report timings and memory.
    Bench(bench::BenchArgs),
    /// Render several methods with the same photons and eye samples and compare them with a
    /// reference (the path tracer at high spp unless --reference is given).
    Compare(compare::CompareArgs),
    /// Tone-map a linear EXR to a PNG or JPEG with the window's tone curves.
    Tonemap(tonemap::TonemapArgs),
    /// Write the project's generated scenes (.glb) into a folder.
    Scenes(scenes::ScenesArgs),
}

/// Parses the command line and runs the command; the process's exit status.
pub fn main() -> i32 {
    let matches = with_ranges(Cli::command()).get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        None => view::run(cli.view),
        Some(Command::View(args)) => view::run(args),
        Some(Command::Render(args)) => {
            return_freed_memory();
            render::run(args)
        }
        Some(Command::Bench(args)) => bench::run(args),
        Some(Command::Compare(args)) => {
            return_freed_memory();
            compare::run(args)
        }
        Some(Command::Tonemap(args)) => tonemap::run(args),
        Some(Command::Scenes(args)) => scenes::run(args),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_status()
        }
    }
}

/// For the headless renders (`render`, `compare`), whose peak is what counts: glibc serves a
/// block of any size up to 32 MiB from its heap once a block that large was freed (the mmap
/// threshold follows the largest freed mapping), and freed heap blocks stay resident, so the
/// eye pass's bands, a light pass's waves and the resolve's maps held about 10 MB of a
/// render's peak that nothing used (docs/benchmarks.md, "Memory"). A fixed threshold of 1 MiB
/// maps every large array of its own, so freeing it gives it back; smaller blocks (the
/// per-task buffers of the hot loops) stay on the heap. The previewer (and `bench`, whose
/// previewer rows measure it) keeps glibc's default: it allocates a film and display buffers
/// per frame, and fresh mappings' page faults cost its re-splat 12% (docs/benchmarks.md).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn return_freed_memory() {
    // SAFETY: mallopt only sets a parameter of the allocator (under its own lock); a refusal
    // (return 0) leaves glibc's default, which is harmless.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 20);
    }
}

/// Other allocators return large blocks on their own terms.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn return_freed_memory() {}

/// Set by the first Ctrl-C (a render then stops after its current step and writes what it
/// has); a second Ctrl-C exits at once with status 130.
fn interrupt_flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        let installed = ctrlc::set_handler(move || {
            if f.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
            eprintln!("\ninterrupted: finishing the current step (Ctrl-C again to quit now)");
        });
        if let Err(e) = installed {
            eprintln!("warning: Ctrl-C will end the program without writing ({e})");
        }
        flag
    })
    .clone()
}

/// A clap value parser for a closed set of named choices.
fn choice<T: Choice>() -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(T::ALL.iter().map(|c| c.name()))
        .map(|s| T::from_name(&s).expect("clap checked the name"))
}

/// Every numeric flag's row of the limits table (`raysplat::settings::limits`), applied to
/// each command that has the flag: the value parser refuses a value outside the range before
/// any work, and the help shows the range. The one place that ties flags to limits.
fn with_ranges(mut cmd: clap::Command) -> clap::Command {
    use raysplat::settings::limits::*;
    cmd = env_ranged(cmd);
    for sub in ["render", "compare", "bench", "tonemap", "view"] {
        cmd = cmd.mut_subcommand(sub, |c| {
            let c = env_ranged(c);
            let c = ranged(c, "width", RESOLUTION);
            let c = ranged(c, "height", RESOLUTION);
            let c = ranged(c, "spp", PT_SPP);
            let c = ranged(c, "photons", PHOTONS);
            let c = smoothness_ranged(c);
            let c = ranged(c, "s", SENSITIVITY_S);
            let c = ranged(c, "r", MAX_BANDWIDTH_R);
            let c = ranged(c, "floor_k", FLOOR_NEIGHBOURS);
            let c = ranged(c, "nee_samples", NEE_SAMPLES);
            let c = ranged(c, "pm_k", PM_K);
            let c = ranged(c, "pm_caustic_k", PM_K);
            let c = ranged(c, "fg_rays", FG_RAYS);
            let c = ranged(c, "cache_error", CACHE_ERROR);
            let c = ranged(c, "min_records", MIN_RECORDS);
            let c = ranged(c, "filter_strength", FILTER_STRENGTH);
            let c = ranged(c, "time_budget", TIME_BUDGET);
            let c = ranged(c, "batches", BATCHES);
            let c = ranged(c, "threads", THREADS);
            let c = ranged(c, "runs", RUNS);
            let c = ranged(c, "ref_spp", PT_SPP);
            ranged(c, "pt_spp", PT_SPP)
        });
    }
    cmd
}

/// `cmd` with `--c` (if it has one) parsed as a C within its range or `auto`.
fn smoothness_ranged(cmd: clap::Command) -> clap::Command {
    use args::Smoothness;
    use raysplat::settings::limits::SMOOTHNESS_C;
    if !cmd.get_arguments().any(|a| a.get_id() == "c") {
        return cmd;
    }
    cmd.mut_arg("c", |a| {
        let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
        let value = in_range(SMOOTHNESS_C);
        // `auto` as `Smoothness` reads it; a number within the range as every ranged flag's.
        a.value_parser(move |s: &str| match s.parse::<Smoothness>() {
            Ok(Smoothness::Auto) => Ok(Smoothness::Auto),
            _ => value(s).map(Smoothness::Value),
        })
        .allow_negative_numbers(true)
        // The same range note as every other numeric flag's; `auto` is in the help text.
        .help(format!(
            "{help} [range: {}..={}]",
            SMOOTHNESS_C.min, SMOOTHNESS_C.max
        ))
    })
}

/// `cmd` with the environment's numeric flags (if it has them) ranged.
fn env_ranged(cmd: clap::Command) -> clap::Command {
    use raysplat::settings::limits::*;
    let c = ranged(cmd, "env_strength", ENV_STRENGTH);
    ranged(c, "env_rotation", ENV_ROTATION)
}

/// `cmd` with the flag `id` (if it has one) parsed by [`in_range`] and its range in the help.
fn ranged<T>(cmd: clap::Command, id: &str, limit: Limit<T>) -> clap::Command
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display + Copy + Send + Sync + 'static,
{
    if !cmd.get_arguments().any(|a| a.get_id() == id) {
        return cmd;
    }
    cmd.mut_arg(id, |a| {
        let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
        let sep = if help.is_empty() { "" } else { " " };
        // A negative number is a value (refused by its range), never taken for a flag.
        a.value_parser(in_range(limit))
            .allow_negative_numbers(true)
            .help(format!("{help}{sep}[range: {}..={}]", limit.min, limit.max))
    })
}

/// A clap value parser for a number within `limit` (one row of the limits table): a value
/// outside it, NaN included, is refused before any work with the flag's name and the range.
fn in_range<T>(
    limit: Limit<T>,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display + Copy + Send + Sync + 'static,
{
    move |s: &str| {
        let v: T = match s.trim().parse() {
            Ok(v) => v,
            // A number, but not of this flag's kind (negative, or a fraction for a count).
            Err(_) if s.trim().parse::<f64>().is_ok() => {
                return Err(format!(
                    "must be in {}..={} (a whole number)",
                    limit.min, limit.max
                ));
            }
            Err(_) => return Err(format!("'{s}' is not a number")),
        };
        if limit.contains(v) {
            Ok(v)
        } else {
            Err(format!("must be in {}..={}", limit.min, limit.max))
        }
    }
}

/// The scene a command names: a glTF file, `builtin:<key>`, or (without one) the embedded
/// CORNELL BOX I.
/// Load the scene (`None`: the embedded one, `builtin:KEY`, or a file), light it with the
/// environment `env` asks for, and print its warnings and lighting notice on stderr.
fn load_scene(arg: Option<&str>, env: &args::EnvArgs) -> Result<Scene, CliError> {
    let mut scene = load_scene_file(arg)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let settings = env.settings();
    if settings != raysplat::scene::EnvironmentSettings::default() {
        scene.set_environment(&settings).map_err(CliError::Input)?;
    }
    if let Some(notice) = &scene.lighting_notice {
        eprintln!("note: {notice} (--environment to choose another)");
    }
    Ok(scene)
}

fn load_scene_file(arg: Option<&str>) -> Result<Scene, CliError> {
    match arg {
        None => Ok(Scene::default_scene()),
        Some(name) if name.starts_with("builtin:") => {
            let key = &name["builtin:".len()..];
            let Some(which) = BuiltinScene::from_key(key) else {
                let keys: Vec<&str> = BuiltinScene::ALL.iter().map(|s| s.key()).collect();
                return Err(CliError::Input(format!(
                    "unknown built-in scene '{key}' ({})",
                    keys.join(", ")
                )));
            };
            Ok(Scene::builtin(which))
        }
        Some(path) => Ok(Scene::load(Path::new(path))?),
    }
}

/// Sizes rayon's global pool (`--threads`); all cores when `None`.
fn set_threads(threads: Option<usize>) -> Result<(), String> {
    if let Some(n) = threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| format!("cannot set up {n} threads: {e}"))?;
    }
    Ok(())
}
