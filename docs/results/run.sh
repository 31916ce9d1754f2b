#!/usr/bin/env bash
# Reproduces docs/results.md. Run from the repository root after `cargo build --release`
# (or with R=path/to/raysplat). Each scene's path-traced reference is rendered once into
# its folder (reference.exr, kept between runs: delete it to re-render) and every method is
# compared against it (compare.json, each method's EXR and error map, and montage.jpg: the
# images over their Fig. 10 error maps, the reference last); photon mapping is also run over a range of K, so that the table can
# quote pm at its best K. About 45 minutes on the 2-core machine of docs/benchmarks.md, most of
# it path tracing.
set -euo pipefail
R=${R:-target/release/raysplat}
S=../shared/scenes
OUT=docs/results

# scene_dir, reference paths per pixel, eye samples per pixel, K of the global map (Table 2's),
# other K values to try, then the render arguments.
run() {
    local dir=$1 ref_spp=$2 spp=$3 k0=$4 ks=$5
    shift 5
    # Table 2's rows take one light sample per eye sample, as they were recorded (the
    # command line's default is 4 since 2026-11-26, docs/deviations.md §57), unless a row
    # says otherwise.
    local nee=(--nee-samples 1)
    [[ " $* " == *" --nee-samples "* ]] && nee=()
    set -- "$@" "${nee[@]}"
    mkdir -p "$OUT/$dir"
    if [ ! -f "$OUT/$dir/reference.exr" ]; then
        $R render "$@" --method pt --spp "$ref_spp" --out "$OUT/$dir/reference.exr"
    fi
    $R compare "$@" --spp "$spp" --pm-k "$k0" --methods rs,pm,pt --pt-spp 16 \
        --reference "$OUT/$dir/reference.exr" --out-dir "$OUT/$dir"
    for k in $ks; do
        $R compare "$@" --spp "$spp" --methods pm --pm-k "$k" \
            --reference "$OUT/$dir/reference.exr" --out-dir "$OUT/$dir/pm_k$k" >/dev/null
    done
}

# CORNELL BOX I, Table 2's settings (500×500×4, M = 200,000, (0.3, 0.6, 0.1), R = 0.2, C = 1, S = 0.4).
run cornell1 1024 4 400 "100 200 800" builtin:cornell1 --width 500 --height 500 \
    --photons 200000 --fractions 0.3,0.6,0.1 --c 1.0 --s 0.4 --r 0.2 --pm-caustic-k 250 --exposure 2.5
# Final gathering on CORNELL BOX I at 250×250×1 with 64 gather rays.
mkdir -p $OUT/cornell1_fg
if [ ! -f $OUT/cornell1_fg/reference.exr ]; then
    $R render builtin:cornell1 --width 250 --height 250 --method pt --spp 1024 \
        --out $OUT/cornell1_fg/reference.exr
fi
$R compare builtin:cornell1 --width 250 --height 250 --spp 1 --nee-samples 1 --photons 200000 --fg-rays 64 \
    --pm-k 100 --pm-caustic-k 50 --exposure 2.5 --methods rs-fg,pm-fg --reference $OUT/cornell1_fg/reference.exr \
    --out-dir $OUT/cornell1_fg
# CORNELL BOX II, Table 2's settings (M = 300,000, (0.2, 0.0, 0.8), C = 1.1, S = 0.5).
run cornell2 1024 4 400 "" builtin:cornell2 --width 500 --height 500 --photons 300000 \
    --fractions 0.2,0.0,0.8 --c 1.1 --s 0.5 --r 0.2 --pm-caustic-k 250 --exposure 2.5
for k in 30 60 125 500; do
    $R compare builtin:cornell2 --width 500 --height 500 --spp 4 --nee-samples 1 --photons 300000 \
        --fractions 0.2,0.0,0.8 --c 1.1 --s 0.5 --r 0.2 --pm-k 400 --pm-caustic-k $k \
        --methods pm --reference $OUT/cornell2/reference.exr --out-dir $OUT/cornell2/pm_ck$k >/dev/null
done
# rs with a wider bandwidth range R (caustic rays sit at h_min = R·h̄).
for r in 0.1 0.05; do
    $R compare builtin:cornell2 --width 500 --height 500 --spp 4 --nee-samples 1 --photons 300000 \
        --fractions 0.2,0.0,0.8 --c 1.1 --s 0.5 --r $r \
        --methods rs --reference $OUT/cornell2/reference.exr --out-dir $OUT/cornell2/rs_r$r >/dev/null
done
# SIBENIK (both cameras) and the apartment (living room), Table 2's settings at 500×375×1
# and 500×333×1 (the files' 4:3 and 3:2 cameras).
if [ -f $S/sibenik.glb ]; then
    for cam in camera_nave camera_apse_to_rose_window; do
        run sibenik_$cam 256 1 500 "30 60 125 250 1000" $S/sibenik.glb --camera $cam --width 500 \
            --height 375 --photons 500000 --fractions 0.0,1.0,0.0 --c 0.9 --s 0.3 --r 0.2 --exposure=-1
    done
fi
# Other seeds on the nave: rs against pm at K = 125.
if [ -f $S/sibenik.glb ]; then
    for seed in 2 3; do
        $R compare $S/sibenik.glb --camera camera_nave --width 500 --height 375 --photons 500000 \
            --spp 1 --nee-samples 1 --fractions 0.0,1.0,0.0 --c 0.9 --s 0.3 --r 0.2 --seed $seed --pm-k 125 \
            --methods rs,pm --reference $OUT/sibenik_camera_nave/reference.exr \
            --out-dir $OUT/sibenik_camera_nave/seed$seed >/dev/null
    done
fi
if [ -f $S/living_room.glb ]; then
    run living_room 256 1 600 "40 75 150 300 1200" $S/living_room.glb --width 500 --height 333 \
        --photons 500000 --fractions 0.0,0.9,0.1 --c 0.9 --s 0.4 --r 0.2 --exposure 1
fi
# OUTDOOR (builtin:outdoor, no light of its own) under the uniform environment and under the
# CIE clear sky with a sun (docs/deviations.md, "Light from afar"), 320×240×4, M = 200,000,
# 4 NEE samples per eye sample.
run outdoor_uniform 1024 4 400 "" builtin:outdoor --width 320 --height 240 --photons 200000 \
    --nee-samples 4 --environment uniform
run outdoor_sky 1024 4 400 "" builtin:outdoor --width 320 --height 240 --photons 200000 \
    --nee-samples 4 --environment sky
# The same with a sun: its caustic through the glass sphere is an L S D path from a 0.53° light,
# which the path tracer finds by chance only (the reference shows it as fireflies).
run outdoor_sun 1024 4 400 "" builtin:outdoor --width 320 --height 240 --photons 200000 \
    --nee-samples 4 --environment sky --sun 35,40 --exposure -1

# Bandwidth clamp fractions (docs/results.md's table): photon-side only, so a tiny image will do;
# CORNELL WATER and SPONZA too, scenes not used for tuning.
mkdir -p $OUT/clamps
clamps() {
    local name=$1
    shift
    $R render "$@" --direct photons --width 40 --height 40 --spp 1 --out /tmp/raysplat_clamps.exr \
        --stats $OUT/clamps/$name.json >/dev/null
}
clamps cornell1 builtin:cornell1 --photons 200000 --fractions 0.3,0.6,0.1 --c 1.0 --s 0.4 --r 0.2
clamps cornell2 builtin:cornell2 --photons 300000 --fractions 0.2,0.0,0.8 --c 1.1 --s 0.5 --r 0.2
for f in sibenik:0.0,1.0,0.0:0.9:0.3 living_room:0.0,0.9,0.1:0.9:0.4 \
    sponza_dabrovic:0.0,1.0,0.0:0.9:0.3 cornell_water:0.3,0.6,0.1:1.0:0.4; do
    IFS=: read -r name fr c s <<<"$f"
    if [ -f $S/$name.glb ]; then
        clamps $name $S/$name.glb --photons 500000 --fractions $fr --c $c --s $s --r 0.2
    fi
done

# The file's own materials against Blender Cycles (an independent renderer: `pip install
# bpy==4.2.0`), 200×200 under the uniform environment. The reference (cycles.exr) is rendered
# once into the scene's folder; the Khronos models get a camera first (tools/with_camera.py).
materials() {
    local dir=$1 scene=$2 cam=$3 map=${4:-}
    # With a map: both renderers lit by it (tools/studio_environment.py), else the uniform one.
    local cyc_env=() rs_env=()
    if [ -n "$map" ]; then
        cyc_env=(--env-map "$(realpath "$map")")
        rs_env=(--environment "$map")
    fi
    mkdir -p "$OUT/$dir"
    if [ ! -f "$OUT/$dir/cycles.exr" ]; then
        # bpy 4.2 may crash on exit after it has written the image: the file decides.
        local abs
        abs=$(realpath "$scene")
        (cd /tmp && python3 "$OLDPWD/tools/cycles_reference.py" "$abs" \
            "$OLDPWD/$OUT/$dir/cycles.exr" --spp 2048 --width 200 --height 200 --camera "$cam" \
            "${cyc_env[@]}") ||
            [ -f "$OUT/$dir/cycles.exr" ]
    fi
    $R compare "$scene" --camera "$cam" --width 200 --height 200 --methods rs,pt --pt-spp 256 \
        "${rs_env[@]}" --reference "$OUT/$dir/cycles.exr" --out-dir "$OUT/$dir"
    # rs under a 10 s budget at its defaults (guided emission), its relMSE against Cycles in
    # rs_10s/compare.json.
    $R compare "$scene" --camera "$cam" --width 200 --height 200 --time-budget 10 --methods rs \
        "${rs_env[@]}" --reference "$OUT/$dir/cycles.exr" --out-dir "$OUT/$dir/rs_10s" >/dev/null
}
python3 -c "import bpy" 2>/dev/null && {
    # Each scene under the uniform environment and under a studio map (suffix _map).
    python3 tools/studio_environment.py "$OUT/studio.exr"
    for env in "" _map; do
        map=
        [ -n "$env" ] && map="$OUT/studio.exr"
        materials "features$env" assets/features.glb features_camera $map
        for m in DamagedHelmet.glb Suzanne/Suzanne.gltf; do
            name=$(basename "${m%.*}")
            if [ -f "$S/khronos/$m" ]; then
                case $name in DamagedHelmet) view="--distance 3.3 --yfov 0.7" ;; *) view="--distance 4.5 --yfov 0.6" ;; esac
                python3 tools/with_camera.py "$S/khronos/$m" "/tmp/raysplat_$name" $view
                materials "khronos_$name$env" "/tmp/raysplat_$name/$(basename "$m")" cam $map
            fi
        done
    done
}
bash docs/results/room.sh
