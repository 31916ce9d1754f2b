#!/usr/bin/env bash
# `--c auto` against every fixed C of {0.4, 0.6, 0.8, 1.0, 1.4, 2.0} at the same photons
# (issue 32's targets; docs/results.md "Automatic bandwidth", docs/deviations.md §51). Each
# scene at one eye sample per pixel, 40 batches of 20,000 photons (the window's settings when
# these runs were recorded, a deterministic count; emission by power and one light sample per
# eye sample, pinned below: the window now guides emission and draws 4, deviations §44, §50),
# against a path-traced reference rendered once into its folder with a
# seed of its own (a run whose compare.json exists is kept). Prints one line per scene: each fixed C's relMSE, the best, auto's relMSE,
# the C it chose and its own estimate. Run from the repository root after
# `cargo build --release`; about 15 minutes on the 2-core machine of docs/benchmarks.md.
set -euo pipefail
R=${R:-target/release/raysplat}
S=../shared/scenes
OUT=docs/results/auto_c
CS="0.4 0.6 0.8 1.0 1.4 2.0"

# name, reference paths per pixel (or an existing reference's path), then the scene arguments.
scene() {
    local name=$1 ref=$2
    shift 2
    mkdir -p "$OUT/$name"
    local reference="$OUT/$name/reference.exr"
    if [ -f "$ref" ]; then
        reference=$ref
    elif [ ! -f "$reference" ]; then
        $R render "$@" --method pt --spp "$ref" --seed 4099 --out "$reference" >/dev/null
    fi
    local line="$name:"
    for c in $CS auto; do
        # A finished run is kept (delete its folder to run it again).
        [ -f "$OUT/$name/c_$c/compare.json" ] ||
            $R compare "$@" --spp 1 --nee-samples 1 --photons 20000 --batches 40 --methods rs --c $c --emission-by-power \
                --reference "$reference" --out-dir "$OUT/$name/c_$c" >/dev/null
        line+=" $c $(jq -r '.methods.rs | "\(.relmse)"' "$OUT/$name/c_$c/compare.json" | xargs printf '%.5f')"
    done
    line+=" | chosen C $(jq -r '.methods.rs.smoothness_c' "$OUT/$name/c_auto/compare.json" | xargs printf '%.2f')"
    line+=", estimated $(jq -r '.methods.rs.estimated_relmse' "$OUT/$name/c_auto/compare.json" | xargs printf '%.5f')"
    echo "$line"
}

scene cornell1 1024 builtin:cornell1 --width 160 --height 160
scene cornell2 1024 builtin:cornell2 --width 160 --height 160
scene classic 1024 builtin:classic --width 160 --height 160
scene room_window docs/results/room_window/reference.exr builtin:room \
    --camera towards_the_window --environment uniform --env-strength 1 --width 160 --height 120
if [ -f $S/sibenik.glb ]; then
    scene sibenik_nave 512 $S/sibenik.glb --camera camera_nave --width 120 --height 90
    scene sibenik_apse 512 $S/sibenik.glb --camera camera_apse_to_rose_window --width 120 --height 90
fi
if [ -f $S/living_room.glb ]; then
    scene living_room 512 $S/living_room.glb --width 120 --height 90
fi
