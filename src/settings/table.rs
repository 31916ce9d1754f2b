//! Every field of [`RenderSettings`] classified in one place ([`SETTINGS`]): what a change of
//! it asks of a running render ([`Effect`]) and its accepted range ([`Range`], from
//! [`super::limits`]). `within_limits` and `validate` walk this table; the worker's rebuild
//! test, its view and update calls and the photon core's `update` read [`Changes`] from it.
//! A field added to `RenderSettings` does not compile until [`classified`] names it, and the
//! test `every_setting_has_its_row` fails until it has its row here.

use super::limits::*;
use super::{Limit, RenderSettings, SettingsError, normalised_fractions};

/// What a change of one setting asks of a running render, cheapest first. No render setting
/// is display-only: exposure and tone curve live in the window's own settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Effect {
    /// The next film is resolved with it (cache, filter, eye passes and NEE's light samples
    /// from the next batch): `Method::update`, nothing re-splatted.
    Resolve,
    /// The stored photon rays are splatted again (bandwidth, the schedule's M₁, the radiance
    /// map's records, the error estimate's accumulators: the last two on a new eye side):
    /// `Method::update`, no re-trace.
    Resplat,
    /// A new eye side (eye samples, splat tree) and a re-splat: `Method::set_view`.
    View,
    /// What is traced changes: the method is built again (`methods::build`).
    Retrace,
}

/// The accepted values of a setting, with the field they bound.
#[derive(Clone, Copy)]
pub enum Range {
    /// A whole number within a limit.
    U32(Limit<u32>, fn(&mut RenderSettings) -> &mut u32),
    /// A whole number within a limit.
    U64(Limit<u64>, fn(&mut RenderSettings) -> &mut u64),
    /// A whole number within a limit.
    Usize(Limit<usize>, fn(&mut RenderSettings) -> &mut usize),
    /// A number within a limit (NaN is outside).
    F32(Limit<f32>, fn(&mut RenderSettings) -> &mut f32),
    /// Three non-negative numbers, not all zero, normalised to sum to 1.
    Fractions,
    /// Every value of its type is accepted (a choice, a switch, a seed, a name).
    Any,
}

/// One row of the table.
#[derive(Clone, Copy)]
pub struct Setting {
    /// The field's path in the settings' JSON (`bandwidth.smoothness_c`).
    pub name: &'static str,
    /// How messages name it.
    pub label: &'static str,
    /// What a change of it asks of a running render.
    pub effect: Effect,
    /// Its accepted values.
    pub range: Range,
    /// True when two settings agree on it.
    pub same: fn(&RenderSettings, &RenderSettings) -> bool,
    /// Copy it from the second settings into the first.
    pub assign: fn(&mut RenderSettings, &RenderSettings),
}

macro_rules! setting {
    ($name:literal, $label:literal, $effect:ident, $($field:ident).+) => {
        Setting {
            name: $name,
            label: $label,
            effect: Effect::$effect,
            range: Range::Any,
            same: |a, b| a.$($field).+ == b.$($field).+,
            assign: |a, b| a.$($field).+ = b.$($field).+.clone(),
        }
    };
    ($name:literal, $label:literal, $effect:ident, $($field:ident).+, $kind:ident($limit:expr)) => {
        Setting {
            name: $name,
            label: $label,
            effect: Effect::$effect,
            range: Range::$kind($limit, |s| &mut s.$($field).+),
            same: |a, b| a.$($field).+ == b.$($field).+,
            assign: |a, b| a.$($field).+ = b.$($field).+,
        }
    };
}

/// Every setting: its name, what a change of it costs, its range. The one place to classify
/// a new field.
pub const SETTINGS: &[Setting] = &[
    setting!("width", "width", View, width, U32(RESOLUTION)),
    setting!("height", "height", View, height, U32(RESOLUTION)),
    setting!("spp", "samples per pixel", View, spp, U32(SPP)),
    setting!("camera", "camera", View, camera),
    setting!("pt_spp", "paths per pixel", Retrace, pt_spp, U32(PT_SPP)),
    // The batch size moves the progressive schedule's M₁ (a re-splat when it does).
    setting!(
        "photons",
        "photons per batch",
        Resplat,
        photons,
        U64(PHOTONS)
    ),
    Setting {
        name: "fractions",
        label: "photon fractions",
        effect: Effect::Retrace,
        range: Range::Fractions,
        same: |a, b| a.fractions == b.fractions,
        assign: |a, b| a.fractions = b.fractions,
    },
    setting!(
        "bandwidth.smoothness_c",
        "C",
        Resplat,
        bandwidth.smoothness_c,
        F32(SMOOTHNESS_C)
    ),
    setting!(
        "bandwidth.sensitivity_s",
        "S",
        Resplat,
        bandwidth.sensitivity_s,
        F32(SENSITIVITY_S)
    ),
    setting!(
        "bandwidth.max_bandwidth_r",
        "R",
        Resplat,
        bandwidth.max_bandwidth_r,
        F32(MAX_BANDWIDTH_R)
    ),
    setting!(
        "bandwidth.floor_neighbours",
        "K floor",
        Resplat,
        bandwidth.floor_neighbours,
        F32(FLOOR_NEIGHBOURS)
    ),
    setting!(
        "progressive_bandwidth",
        "progressive bandwidth",
        Resplat,
        progressive_bandwidth
    ),
    // New accumulators with the new directional records, then a re-splat.
    setting!("radiance_map", "radiance map", Resplat, radiance_map),
    setting!("seed", "seed", Retrace, seed),
    setting!("direct", "direct light", Retrace, direct),
    setting!(
        "max_specular_depth",
        "specular depth",
        Retrace,
        max_specular_depth,
        U32(SPECULAR_DEPTH)
    ),
    setting!(
        "nee_samples",
        "NEE samples",
        Resolve,
        nee_samples,
        U32(NEE_SAMPLES)
    ),
    setting!(
        "max_emitted_factor",
        "emitted photons per stored photon",
        Retrace,
        max_emitted_factor,
        U64(MAX_EMITTED_FACTOR)
    ),
    setting!(
        "merge_targets",
        "merge splat targets",
        Retrace,
        merge_targets
    ),
    setting!(
        "splat_visibility",
        "visibility in the splat footprint",
        Retrace,
        splat_visibility
    ),
    setting!(
        "guided_emission",
        "photons where the camera looks",
        Retrace,
        guided_emission
    ),
    // A new eye side with (or without) the half-bandwidth accumulators, then a re-splat.
    setting!("estimate_error", "error estimate", Resplat, estimate_error),
    setting!("auto_c", "automatic C", Resolve, auto_c),
    setting!("method", "method", Retrace, method),
    setting!("pm_k", "K", Retrace, pm_k, Usize(PM_K)),
    setting!(
        "pm_caustic_k",
        "caustic K",
        Retrace,
        pm_caustic_k,
        Usize(PM_K)
    ),
    setting!("fg_rays", "gather rays", Retrace, fg_rays, U32(FG_RAYS)),
    setting!(
        "cache.error",
        "cache error",
        Resolve,
        cache.error,
        F32(CACHE_ERROR)
    ),
    setting!(
        "cache.min_records",
        "cache records",
        Resolve,
        cache.min_records,
        U32(MIN_RECORDS)
    ),
    setting!("cache_on", "radiance cache", Resolve, cache_on),
    setting!("filter.enabled", "filter", Resolve, filter.enabled),
    setting!(
        "filter.strength",
        "filter strength",
        Resolve,
        filter.strength,
        F32(FILTER_STRENGTH)
    ),
    setting!(
        "progressive_eye",
        "progressive eye passes",
        Resolve,
        progressive_eye
    ),
];

/// Names every field of [`RenderSettings`] without `..`: a new field does not compile here
/// until it is added, which is the reminder to give it its row in [`SETTINGS`] (the test
/// `every_setting_has_its_row` then checks the row is there).
#[allow(dead_code)]
pub(super) fn classified(s: &RenderSettings) {
    let RenderSettings {
        width: _,
        height: _,
        spp: _,
        photons: _,
        fractions: _,
        bandwidth: _,
        seed: _,
        direct: _,
        max_specular_depth: _,
        nee_samples: _,
        max_emitted_factor: _,
        camera: _,
        merge_targets: _,
        splat_visibility: _,
        method: _,
        pm_k: _,
        pm_caustic_k: _,
        fg_rays: _,
        pt_spp: _,
        radiance_map: _,
        cache: _,
        cache_on: _,
        filter: _,
        progressive_eye: _,
        progressive_bandwidth: _,
        guided_emission: _,
        estimate_error: _,
        auto_c: _,
    } = s;
}

impl Range {
    /// Move the field into its range (NaN to the lower bound; fractions that cannot be
    /// normalised to the defaults).
    pub fn clamp(&self, s: &mut RenderSettings) {
        match *self {
            Range::U32(l, f) => *f(s) = l.clamp(*f(s)),
            Range::U64(l, f) => *f(s) = l.clamp(*f(s)),
            Range::Usize(l, f) => *f(s) = l.clamp(*f(s)),
            Range::F32(l, f) => *f(s) = l.clamp(*f(s)),
            Range::Fractions => {
                s.fractions = normalised_fractions(s.fractions)
                    .unwrap_or_else(|_| RenderSettings::default().fractions);
            }
            Range::Any => {}
        }
    }

    /// An error naming the setting (`label`) when its value in `s` is outside the range (read
    /// through the row's accessor, hence `&mut`; nothing is written).
    pub fn check(&self, label: &'static str, s: &mut RenderSettings) -> Result<(), SettingsError> {
        fn within<T: Copy + PartialOrd + std::fmt::Display>(
            label: &'static str,
            l: Limit<T>,
            v: T,
        ) -> Result<(), SettingsError> {
            if l.contains(v) {
                Ok(())
            } else {
                Err(SettingsError::OutOfRange {
                    label,
                    range: format!("{}..={}", l.min, l.max),
                    value: v.to_string(),
                })
            }
        }
        match *self {
            Range::U32(l, f) => within(label, l, *f(s)),
            Range::U64(l, f) => within(label, l, *f(s)),
            Range::Usize(l, f) => within(label, l, *f(s)),
            Range::F32(l, f) => within(label, l, *f(s)),
            Range::Fractions => normalised_fractions(s.fractions).map(|_| ()),
            Range::Any => Ok(()),
        }
    }
}

/// Which kinds of change lie between two settings.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Changes {
    /// The names of the settings that differ, in the table's order.
    pub names: Vec<&'static str>,
    /// Some setting of each effect differs (indexed by `Effect as usize`).
    effects: [bool; 4],
}

impl Changes {
    /// What differs from `old` to `new`.
    pub fn between(old: &RenderSettings, new: &RenderSettings) -> Self {
        let mut c = Changes::default();
        for s in SETTINGS {
            if !(s.same)(old, new) {
                c.names.push(s.name);
                c.effects[s.effect as usize] = true;
            }
        }
        c
    }

    /// Some setting with this effect differs.
    pub fn any(&self, effect: Effect) -> bool {
        self.effects[effect as usize]
    }
}

impl RenderSettings {
    /// Take from `other` every setting whose change has one of `effects`.
    pub fn adopt(&mut self, other: &RenderSettings, effects: &[Effect]) {
        for s in SETTINGS {
            if effects.contains(&s.effect) {
                (s.assign)(self, other);
            }
        }
    }
}
