#!/usr/bin/env bash
# docs/results/auto_c.sh with emission guided as by default (deviations §44) instead of by
# power: every fixed C of {0.4, 0.6, 0.8, 1.0, 1.4, 2.0}, `--c auto`, and `--c auto
# --paper-bandwidth-rate` (auto without the progressive schedule, "autopaper"), 40 batches of
# 20,000 photons, one eye sample and one light sample, against auto_c.sh's references (a
# run whose compare.json exists is kept). Prints one line per scene. About 20 minutes here.
set -euo pipefail
R=${R:-target/release/raysplat}
S=../shared/scenes
OUT=docs/results/auto_c_guided
REF=docs/results/auto_c
CS="${CS:-0.4 0.6 0.8 1.0 1.4 2.0 auto autopaper}"
scene() {
    local name=$1; shift
    local reference="$REF/$name/reference.exr"
    [ -f "$reference" ] || reference=$1
    shift
    mkdir -p "$OUT/$name"
    local line="$name:"
    for c in $CS; do
        local extra=(--c $c)
        [ $c = autopaper ] && extra=(--c auto --paper-bandwidth-rate)
        [ -f "$OUT/$name/c_$c/compare.json" ] ||
            $R compare "$@" --spp 1 --nee-samples 1 --photons 20000 --batches 40 --methods rs "${extra[@]}" \
                --reference "$reference" --out-dir "$OUT/$name/c_$c" >/dev/null
        line+=" $c $(jq -r '.methods.rs | "\(.relmse)"' "$OUT/$name/c_$c/compare.json" | xargs printf '%.5f')"
    done
    for c in auto autopaper; do
      [ -f "$OUT/$name/c_$c/compare.json" ] && line+=" | $c C $(jq -r '.methods.rs.smoothness_c' "$OUT/$name/c_$c/compare.json" | xargs printf '%.2f')"
    done
    echo "$line"
}
scene cornell1 x builtin:cornell1 --width 160 --height 160
scene cornell2 x builtin:cornell2 --width 160 --height 160
scene classic x builtin:classic --width 160 --height 160
scene room_window docs/results/room_window/reference.exr builtin:room \
    --camera towards_the_window --environment uniform --env-strength 1 --width 160 --height 120
if [ -f $S/sibenik.glb ]; then
    scene sibenik_nave x $S/sibenik.glb --camera camera_nave --width 120 --height 90
    scene sibenik_apse x $S/sibenik.glb --camera camera_apse_to_rose_window --width 120 --height 90
fi
scene living_room x $S/living_room.glb --width 120 --height 90
