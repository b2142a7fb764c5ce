#!/usr/bin/env bash
# The peer comparison (README, "Accuracy against the peers"): builds host-sim and sick-dump,
# makes a Python virtual environment with the pinned peers (requirements.txt) under
# target/peers/venv, then runs compare.py: every recording, loc-core and each peer from the
# initial pose and from the true pose, one table.
#   scripts/peers/compare.sh            the full comparison (about 2 h on 2 cores from nothing)
#   scripts/peers/compare.sh --quick    paper-10m seed 1 only (about a minute)
#   scripts/peers/compare.sh --tune     the grid behind configs.json (tuning.json)
#   scripts/peers/compare.sh --sweep    the drives with the scanner's sweep, every localiser
#                                       de-skewing (target/peers-sweep; with --quick too)
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
venv="$root/target/peers/venv"
cargo build --release --quiet --manifest-path "$root/Cargo.toml" -p host-sim -p sick-dump
if [ ! -x "$venv/bin/python" ] || ! cmp -s "$root/scripts/peers/requirements.txt" "$venv/requirements.txt"; then
    echo "peers: installing the pinned peers into $venv" >&2
    rm -rf "$venv"
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$root/scripts/peers/requirements.txt"
    cp "$root/scripts/peers/requirements.txt" "$venv/requirements.txt"
fi
exec "$venv/bin/python" "$root/scripts/peers/compare.py" "$@"
