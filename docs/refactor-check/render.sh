#!/bin/bash
# Seeded renders of every method for a bit-for-bit check of a refactor (docs/benchmarks.md,
# "The photon core remodelled changed no number"): run with the binary before and after,
# then compare.py BEFORE_DIR AFTER_DIR (needs pip OpenEXR numpy). S is ../shared/scenes.
# usage: run.sh BINARY OUTDIR
B=$1; O=$2; mkdir -p $O
S=${S:-../shared/scenes}
common="--width 96 --height 72 --spp 2 --photons 20000 --seed 3"
i=0
run() { i=$((i+1)); name=$1; shift; $B render "$@" $common --out $O/$name.exr --stats $O/$name.json >/dev/null 2>$O/$name.err || echo "FAIL $name"; }
for sc in builtin:cornell1 builtin:cornell2 builtin:classic builtin:glossy builtin:glossy-sharp builtin:outdoor $S/cornell_water.glb $S/sponza_dabrovic.glb; do
  n=$(basename $sc .glb | tr ':' '_')
  for m in rs rc pm pt; do run ${n}_$m $sc --method $m --batches 3; done
  for m in rs-fg pm-fg; do run ${n}_$m $sc --method $m --fg-rays 4 --batches 1; done
done
run c1_rs_photons builtin:cornell1 --method rs --direct photons --batches 3
run c1_rs_cache builtin:cornell1 --method rs --cache --batches 2
run c1_rs_filter builtin:cornell1 --method rs --filter --batches 2
run c1_rs_vis builtin:cornell1 --method rs --splat-visibility --batches 2
run c1_rc_photons builtin:cornell1 --method rc --direct photons --batches 2
run c1_pm_photons builtin:cornell1 --method pm --direct photons --batches 2
run c1_rs_fixed builtin:cornell1 --method rs --fixed-eye-samples --paper-bandwidth-rate --batches 3
run c1_rs_strata builtin:cornell1 --method rs --radiance-map histogram --batches 2
run outdoor_sky builtin:outdoor --method rs --environment sky --sun 30,40 --batches 2
echo ran $i
