use super::*;

#[test]
fn limits_clamp_and_reject_nan() {
    assert_eq!(limits::SPP.clamp(0), 1);
    assert_eq!(limits::SPP.clamp(1000), 64);
    assert_eq!(limits::SMOOTHNESS_C.clamp(f32::NAN), 0.05);
    assert!(!limits::SMOOTHNESS_C.contains(f32::NAN));
    assert!(limits::SENSITIVITY_S.contains(1.0));
}

#[test]
fn fractions_are_normalised_or_refused() {
    assert_eq!(
        normalised_fractions([3.0, 6.0, 1.0]).unwrap(),
        [0.3, 0.6, 0.1]
    );
    assert!(normalised_fractions([0.0; 3]).is_err());
    assert!(normalised_fractions([-1.0, 1.0, 1.0]).is_err());
    assert!(normalised_fractions([f32::NAN, 1.0, 1.0]).is_err());
    let s = RenderSettings {
        spp: 0,
        fractions: [0.0; 3],
        ..RenderSettings::default()
    }
    .within_limits();
    assert_eq!(s.spp, 1);
    assert_eq!(s.fractions, RenderSettings::default().fractions);
}

#[test]
fn validate_names_the_setting_and_its_range() {
    assert!(RenderSettings::default().validate().is_ok());
    let e = RenderSettings {
        width: 4_294_967_295,
        ..RenderSettings::default()
    }
    .validate()
    .unwrap_err();
    assert_eq!(e.to_string(), "width must be in 8..=4096, got 4294967295");
    let e = RenderSettings {
        cache: CacheParams {
            error: f32::NAN,
            min_records: 4,
        },
        ..RenderSettings::default()
    }
    .validate()
    .unwrap_err();
    assert!(e.to_string().starts_with("cache error must be in"), "{e}");
    // Whatever within_limits gives is valid.
    let wild = RenderSettings {
        spp: 0,
        photons: u64::MAX,
        fractions: [f32::NAN, 0.0, 0.0],
        ..RenderSettings::default()
    };
    assert!(wild.within_limits().validate().is_ok());
}

#[test]
fn method_names_round_trip() {
    for &m in MethodKind::ALL {
        assert_eq!(MethodKind::from_name(m.name()), Some(m));
        let json = serde_json::to_string(&m).unwrap();
        assert_eq!(json, format!("\"{}\"", m.name()));
    }
}

/// The JSON paths of every leaf of the settings (objects are walked, arrays are leaves).
fn leaves(v: &serde_json::Value, prefix: &str, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, v) in m {
                let path = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                leaves(v, &path, out);
            }
        }
        _ => out.push(prefix.to_string()),
    }
}

/// Every field of `RenderSettings` (as the stats JSON names it) has exactly one row in the
/// table, and every row names a field: a field added without its row fails here.
#[test]
fn every_setting_has_its_row() {
    let mut fields = Vec::new();
    leaves(
        &serde_json::to_value(RenderSettings::default()).unwrap(),
        "",
        &mut fields,
    );
    fields.sort();
    let mut rows: Vec<String> = SETTINGS.iter().map(|s| s.name.to_string()).collect();
    rows.sort();
    assert_eq!(fields, rows);
}

/// Each row's accessor and comparison read the field the row names: moving it through the
/// accessor changes that JSON leaf and no other, and `Changes` reports that row alone.
#[test]
fn each_row_reads_its_own_field() {
    let base = RenderSettings::default();
    let json = |s: &RenderSettings| {
        let mut l = Vec::new();
        leaves(&serde_json::to_value(s).unwrap(), "", &mut l);
        let v = serde_json::to_value(s).unwrap();
        l.into_iter()
            .map(|p| {
                let ptr = format!("/{}", p.replace('.', "/"));
                (p, v.pointer(&ptr).unwrap().clone())
            })
            .collect::<Vec<_>>()
    };
    let before = json(&base);
    for row in SETTINGS {
        let mut s = base.clone();
        match row.range {
            Range::U32(l, f) => *f(&mut s) = if *f(&mut s) == l.max { l.min } else { l.max },
            Range::U64(l, f) => *f(&mut s) = if *f(&mut s) == l.max { l.min } else { l.max },
            Range::Usize(l, f) => *f(&mut s) = if *f(&mut s) == l.max { l.min } else { l.max },
            Range::F32(l, f) => *f(&mut s) = if *f(&mut s) == l.max { l.min } else { l.max },
            Range::Fractions | Range::Any => s = moved_by_json(&base, row.name),
        }
        let changed: Vec<String> = json(&s)
            .into_iter()
            .zip(&before)
            .filter(|(a, b)| a.1 != b.1)
            .map(|(a, _)| a.0)
            .collect();
        assert_eq!(changed, vec![row.name.to_string()], "row {}", row.name);
        assert_eq!(
            Changes::between(&base, &s).names,
            vec![row.name],
            "row {}",
            row.name
        );
        // Within the limits, so validate accepts the moved value.
        assert!(s.validate().is_ok(), "row {}", row.name);
        // The row's `assign` copies exactly that field.
        let mut copied = base.clone();
        (row.assign)(&mut copied, &s);
        assert_eq!(copied, s, "row {}", row.name);
    }
    let other = RenderSettings {
        method: MethodKind::Pm,
        camera: Some("side".into()),
        cache_on: true,
        ..base.clone()
    };
    let c = Changes::between(&base, &other);
    assert_eq!(c.names, vec!["camera", "method", "cache_on"]);
    assert!(c.any(Effect::Retrace) && c.any(Effect::View) && c.any(Effect::Resolve));
    assert!(!c.any(Effect::Resplat));
}

/// `base` with the JSON leaf `name` set to another value its type accepts (a flipped switch,
/// the next whole number, another named choice, a camera name, other fractions).
fn moved_by_json(base: &RenderSettings, name: &str) -> RenderSettings {
    let mut v = serde_json::to_value(base).unwrap();
    let ptr = format!("/{}", name.replace('.', "/"));
    let old = v.pointer(&ptr).unwrap().clone();
    let candidates: Vec<serde_json::Value> = match &old {
        serde_json::Value::Bool(b) => vec![serde_json::json!(!b)],
        serde_json::Value::Number(n) => vec![serde_json::json!(n.as_u64().unwrap() + 1)],
        serde_json::Value::Null => vec![serde_json::json!("side")],
        serde_json::Value::Array(_) => vec![serde_json::json!([0.5, 0.5, 0.0])],
        serde_json::Value::String(_) => ["pm", "photons", "histogram", "diffuse"]
            .iter()
            .map(|c| serde_json::json!(c))
            .collect(),
        serde_json::Value::Object(_) => panic!("{name} is not a leaf"),
    };
    for c in candidates {
        if c == old {
            continue;
        }
        *v.pointer_mut(&ptr).unwrap() = c;
        if let Ok(s) = serde_json::from_value::<RenderSettings>(v.clone()) {
            return s;
        }
        *v.pointer_mut(&ptr).unwrap() = old.clone();
    }
    panic!("no other value found for {name}")
}

/// The settings whose change re-traces are the ones the worker rebuilt the method for before
/// the table existed; the view's are the view's; the rest reach a running method by update.
#[test]
fn the_effects_are_the_documented_ones() {
    let of = |e: Effect| -> Vec<&str> {
        SETTINGS
            .iter()
            .filter(|s| s.effect == e)
            .map(|s| s.name)
            .collect()
    };
    assert_eq!(
        of(Effect::Retrace),
        vec![
            "pt_spp",
            "fractions",
            "seed",
            "direct",
            "max_specular_depth",
            "max_emitted_factor",
            "merge_targets",
            "splat_visibility",
            "guided_emission",
            "method",
            "pm_k",
            "pm_caustic_k",
            "fg_rays"
        ]
    );
    assert_eq!(of(Effect::View), vec!["width", "height", "spp", "camera"]);
    assert_eq!(
        of(Effect::Resplat),
        vec![
            "photons",
            "bandwidth.smoothness_c",
            "bandwidth.sensitivity_s",
            "bandwidth.max_bandwidth_r",
            "bandwidth.floor_neighbours",
            "progressive_bandwidth",
            "radiance_map",
            "estimate_error"
        ]
    );
}
