#!/usr/bin/env bash
# What LME buys on E1 (docs/eigen.md, "E1 in cleave study"): the panel of
# scenes/eigen_e1_panel.toml with the linear hat and LME (its default
# gamma, 4), at three neighbourhood radii; the metric is the time the
# crack starts (the first point eroded beyond the initial 40), against the
# time the explicit crack's J reaches G_c (27.84 s: flank displacement
# 6.835e-3 at 2.5e-4 per second after the half-second ramp; eigen_e1.sh).
# About a minute on two cores.
# Usage, from the repository root:
#   cargo build --release -p cleave-client
#   [CLEAVE=target/release/cleave] [OUT=/tmp/eigen_e1_study] bash docs/scripts/eigen_e1_study.sh
set -euo pipefail
cleave=${CLEAVE:-target/release/cleave}
out=${OUT:-/tmp/eigen_e1_study}
mkdir -p "$out"
# lme_gamma belongs to LME only: the study's scene leaves it at its default
sed '/^lme_gamma/d; s/^end = 40.0/end = 32.0/' scenes/eigen_e1_panel.toml > "$out/e1.toml"
"$cleave" study "$out/e1.toml" \
    --vary grid.shape_function=linear,lme \
    --vary materials.panel.eigen.epsilon=0.0375,0.05,0.075 \
    --metric arrival:eroded_particles=41 --reference analytic:27.84 \
    --out "$out/study"
