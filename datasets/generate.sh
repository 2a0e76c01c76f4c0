#!/usr/bin/env bash
# Regenerates every simulated data set byte for byte: runs each `robocal simulate` line of
# datasets/README.md. Run from the repository root: bash datasets/generate.sh
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p datasets/case_a datasets/case_b_sim datasets/case_c datasets/case_d datasets/nongeometric_robot
grep '^robocal simulate ' datasets/README.md | while read -r _ args; do
  echo "robocal $args" >&2
  # shellcheck disable=SC2086
  cargo run --release --locked -q -- $args
done
