#!/usr/bin/env bash
# Rooms lit from outside (issue 30), at the window's settings (one eye sample per pixel with
# 4 light samples each, 20,000 photons a batch, emission guided by what reached the eye
# samples, C chosen by the render: deviations §44, §50, §51) against the built-in path tracer at equal wall time: 2, 10 and
# 30 s. References: the path tracer at 32,768 paths per pixel for the room (4,096 before
# 2026-11-29, whose own noise, relMSE 0.0023, was a third of the path tracer's error at 30 s;
# about 9 minutes each here) and 16,384 for the apartment (2,048 before; about 8 minutes)
# (the room is Lambertian, so it
# agrees with Cycles: docs/results.md), rendered once into each folder with a seed of their
# own (with the compared runs' seed the path tracer would replay the reference's first paths). Run from the
# repository root after `cargo build --release`; called by run.sh; about 10 minutes here.
set -euo pipefail
R=${R:-target/release/raysplat}
S=../shared/scenes
OUT=docs/results

# name, reference paths per pixel, then the render arguments.
room() {
    local name=$1 ref_spp=$2
    shift 2
    mkdir -p "$OUT/$name"
    if [ ! -f "$OUT/$name/reference.exr" ]; then
        $R render "$@" --method pt --spp "$ref_spp" --seed 4099 --out "$OUT/$name/reference.exr" >/dev/null
    fi
    for t in 2 10 30; do
        mkdir -p "$OUT/${name}_${t}s"
        $R compare "$@" --spp 1 --nee-samples 4 --photons 20000 --c auto --time-budget $t --methods rs,pt \
            --reference "$OUT/$name/reference.exr" --out-dir "$OUT/${name}_${t}s" | tail -3
    done
}
room room_window 32768 builtin:room --camera towards_the_window --environment uniform \
    --env-strength 1 --width 160 --height 120
room room_back_wall 32768 builtin:room --camera towards_the_back_wall --environment uniform \
    --env-strength 1 --width 160 --height 120
if [ -f $S/living_room.glb ]; then
    room living_room_sky 16384 $S/living_room.glb --environment sky --env-strength 3 \
        --width 120 --height 90
fi
