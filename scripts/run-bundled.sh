#!/usr/bin/env bash
# usage: scripts/run-bundled.sh BINARY OUTROOT   (from a checkout's root)
# Simulates every bundled scenario without [planner] (--runs 2 --seed 7) and
# plans five (--runs 3 --seed 7), into OUTROOT; compare two such roots with
# scripts/compare-outputs.py.
bin=$1; root=$2; mkdir -p $root
for f in scenarios/*.toml; do
  n=$(basename $f .toml)
  if grep -q '^\[planner\]' $f; then continue; fi
  timeout 600 nice $bin simulate $f --runs 2 --seed 7 --out $root/sim-$n -q > $root/sim-$n.log 2>&1; echo "$n $?" >> $root/status
done
for n in demo monaco-plan-20m-tactical monaco-network-plan helsinki-network-plan helsinki-plan-mems; do
  timeout 900 nice $bin plan scenarios/$n.toml --runs 3 --seed 7 --out $root/plan-$n -q > $root/plan-$n.log 2>&1; echo "plan-$n $?" >> $root/status
done
