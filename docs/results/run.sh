#!/usr/bin/env bash
# Reproduces docs/results.md. Run from the repository root after `cargo build --release`.
set -euo pipefail
R=target/release/raysplat
S=../shared/scenes
OUT=docs/results
# CORNELL BOX I, Table 2's settings (500×500×4, M = 200,000, (0.3, 0.6, 0.1), R = 0.2, C = 1, S = 0.4).
$R compare --width 500 --height 500 --spp 4 --photons 200000 --fractions 0.3,0.6,0.1 \
    --c 1.0 --s 0.4 --r 0.2 --methods rs,pm,pt --pt-spp 16 --ref-spp 1024 --out-dir $OUT/cornell1
# Final gathering on CORNELL BOX I at 250×250×1 with 64 gather rays.
$R compare --width 250 --height 250 --spp 1 --photons 200000 --fg-rays 64 --pm-k 100 \
    --pm-caustic-k 50 --methods rs-fg,pm-fg --ref-spp 1024 --out-dir $OUT/cornell1_fg
# CORNELL BOX II, Table 2's settings (M = 300,000, (0.2, 0.0, 0.8), C = 1.1, S = 0.5).
$R compare builtin:cornell2 --width 500 --height 500 --spp 4 --photons 300000 \
    --fractions 0.2,0.0,0.8 --c 1.1 --s 0.5 --r 0.2 --pm-k 400 --pm-caustic-k 250 \
    --methods rs,pm,pt --pt-spp 16 --ref-spp 1024 --out-dir $OUT/cornell2
# SIBENIK and the apartment (living room), Table 2's settings at 500×375×1 (4:3 cameras).
if [ -f $S/sibenik.glb ]; then
    $R compare $S/sibenik.glb --width 500 --height 375 --spp 1 --photons 500000 \
        --fractions 0.0,1.0,0.0 --c 0.9 --s 0.3 --r 0.2 --pm-k 500 \
        --methods rs,pm,pt --pt-spp 16 --ref-spp 256 --out-dir $OUT/sibenik
fi
if [ -f $S/living_room.glb ]; then
    $R compare $S/living_room.glb --width 500 --height 333 --spp 1 --photons 500000 \
        --fractions 0.0,0.9,0.1 --c 0.9 --s 0.4 --r 0.2 --pm-k 600 \
        --methods rs,pm,pt --pt-spp 16 --ref-spp 256 --out-dir $OUT/living_room
fi
