#!/usr/bin/env bash
# Runs every test of the project: host unit, property and integration tests of the
# workspace, lints, the core's Cortex-M build, the landmark search on a one-node Slurm
# cluster, report.html in headless Chromium, and the firmware under QEMU.
# Ends with one line `Summary: N passed, N failed` (cargo's `test result:` lines are
# summed into it, plus one count per non-cargo step).
set -uo pipefail
cd "$(dirname "$0")/.."

log=$(mktemp)
steps_passed=0
steps_failed=0
failed_steps=()

step() {
  local name=$1; shift
  echo "==> $name"
  if "$@" 2>&1 | tee -a "$log"; then
    steps_passed=$((steps_passed + 1))
  else
    steps_failed=$((steps_failed + 1))
    failed_steps+=("$name")
  fi
}

step "setup" bash scripts/setup.sh
step "rustfmt" cargo fmt --all -- --check
step "clippy (host workspace)" cargo clippy --workspace --all-targets --release -- -D warnings
step "cargo test (host workspace)" cargo test --workspace --release --no-fail-fast
step "loc-core for thumbv7em-none-eabihf" \
  cargo build -p loc-core --release --target thumbv7em-none-eabihf
step "landmark search through Slurm job arrays (one-node cluster)" bash scripts/slurm/test-slurm.sh
step "report.html in headless Chromium" bash scripts/check-report-render.sh
if [ -x firmware/run-qemu-tests.sh ]; then
  step "firmware under QEMU" firmware/run-qemu-tests.sh
fi

# Sum cargo's own per-binary results.
read -r t_pass t_fail < <(grep -E '^test result:' "$log" \
  | sed -E 's/.* ([0-9]+) passed; ([0-9]+) failed.*/\1 \2/' \
  | awk '{p += $1; f += $2} END {print p + 0, f + 0}')
rm -f "$log"

echo
if [ ${#failed_steps[@]} -gt 0 ]; then
  printf 'failed step: %s\n' "${failed_steps[@]}"
fi
echo "Summary: $((t_pass + steps_passed)) passed, $((t_fail + steps_failed)) failed"
[ "$steps_failed" -eq 0 ] && [ "$t_fail" -eq 0 ]
