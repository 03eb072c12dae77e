#!/usr/bin/env bash
# usage: .ci/capture-runs.sh REPO OUTDIR [extra run flags, e.g. --ideal]: every built-in scenario x observer (JSON), three runs' CSVs, identify on the presets and motor files, the robustness and supervision sweeps, from REPO's release pmsm-sim. Compare two captures with .ci/compare-runs.py OLD NEW (a refactor must leave them identical).
set -u
repo=$1; out=$2; shift 2; extra="$*"
bin=$repo/target/release/pmsm-sim
mkdir -p $out/runs $out/csv $out/identify
cd $repo
for f in host-sim/scenarios/*.toml; do
  s=$(basename $f .toml)
  for o in encoder sliding-velocity sliding-torque flux flux-ii; do
    $bin run $s --observer $o $extra --json > $out/runs/$s.$o.json 2>&1
    echo "$s $o $?" >> $out/runs/exit.txt
  done
done
for s in start-stop-reverse horng-ramp-brake ortega-load-200; do
  for o in sliding-torque flux; do
    $bin run $s --observer $o $extra --out $out/csv/$s.$o > /dev/null 2>&1
    rm -f $out/csv/$s.$o/run.png
  done
done
for m in sinano ortega-sim-40kw ortega-test-0.3kw ortega-dynamo-1kw; do
  $bin identify --motor $m --json > $out/identify/$m.json 2>&1; echo "$m $?" >> $out/identify/exit.txt
done
for f in host-sim/motors/*.toml; do
  m=$(basename $f .toml)
  $bin identify --motor-file $f --json > $out/identify/$m.json 2>&1; echo "$m $?" >> $out/identify/exit.txt
done
for mx in robustness supervision; do
  $bin sweep --matrix host-sim/matrices/$mx.toml --json > $out/$mx.json 2>$out/$mx.err; echo "$mx $?" >> $out/sweep-exit.txt
done
