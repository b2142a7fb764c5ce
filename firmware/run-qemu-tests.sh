#!/usr/bin/env bash
# Builds the firmware for QEMU mps2-an386 (release; linked into the STM32F407's 1 MiB flash
# and 128 KiB SRAM, memory/mps2-an386.x), runs the on-target self-tests and the
# instruction-count benchmark under QEMU, and checks the result:
#   - selftest: every test passes, and the bytes it sent on UART0 arrive on the host;
#   - bench: the end-to-end pipeline stays within its instruction budget per scan and the
#     RAM budget (static + stack high-water mark <= 96 KiB), against the recording's map
#     image and the same tunnel's 1 km and 10 km images (the map is read in place: RAM
#     does not grow with it);
#   - the controller against the LMS5xx emulator, and its RAM at the end of that run.
# Prints the per-stage instruction counts, a cargo-style `test result:` line (summed by
# scripts/test-all.sh) and `N passed, N failed`. Exits non-zero on any failure.
# Needs: qemu-system-arm (scripts/setup.sh) and defmt-print (installed here if missing).
set -uo pipefail
cd "$(dirname "$0")"

DEFMT_PRINT_VERSION=1.2.0
QEMU_TIMEOUT_S=${QEMU_TIMEOUT_S:-300}
# 1 (default): an end-to-end instruction count over the budget fails the run. 0: it is
# reported loudly but not counted as a failure (for landing work while loc-core is tuned).
FW_BUDGET_ENFORCE=${FW_BUDGET_ENFORCE:-1}
target_dir=${CARGO_TARGET_DIR:-$PWD/target}
elf_dir=$target_dir/thumbv7em-none-eabihf/release
work=$(mktemp -d)
# The test builds of the controller stop after a few scans or stall; whatever happens,
# leave the product build in the target directory, where `host-sim hil` takes it.
trap 'rm -rf "$work"; cargo build --release --quiet --bin controller >/dev/null 2>&1' EXIT

passed=0
failed=0
pass() { passed=$((passed + 1)); echo "ok: $1"; }
fail() { failed=$((failed + 1)); echo "FAILED: $1"; }

if ! command -v qemu-system-arm >/dev/null 2>&1; then
  echo "qemu-system-arm not found: run scripts/setup.sh first" >&2
  exit 1
fi
if ! command -v defmt-print >/dev/null 2>&1; then
  echo "installing defmt-print $DEFMT_PRINT_VERSION (decodes the firmware's defmt log)"
  cargo install defmt-print --locked --version "$DEFMT_PRINT_VERSION" --quiet || exit 1
fi

# Runs ELF under QEMU (qemu-run.sh: instruction-counting clock, the recorded map and start
# pose in the map flash region) with UART0 captured to $2, and prints the decoded defmt log.
# Status: the firmware's semihosting exit (0 ok, 1 failure), 124 time-out.
run_qemu() {
  local elf=$1 uart=$2
  shift 2
  QEMU_SERIAL="file:$uart" QEMU_VEHICLE_OUT="$uart.vehicle" ./qemu-run.sh "$elf" "$@"
}

echo "--> controller-wire (the vehicle interface frames) on the host"
if cargo test -p controller-wire --target "$(rustc -vV | sed -n 's/^host: //p')"; then
  pass "controller-wire host tests"
else
  fail "controller-wire host tests"
fi

echo "--> build (release, thumbv7em-none-eabihf, board mps2-an386: product and testbench)"
if cargo build --release --workspace --bins; then pass "build"; else fail "build"; fi
echo "--> clippy (firmware and testbench, -D warnings)"
if cargo clippy --release --workspace --bins -- -D warnings; then pass "clippy"; else fail "clippy"; fi

echo "--> build for the real boards (NUCLEO-H743ZI2 with stm32h7xx-hal, STM32F407 with stm32f4xx-hal; defmt-rtt)"
if CARGO_TARGET_DIR=$target_dir/nucleo-h743zi cargo build --release --bins -p firmware \
  --no-default-features --features board-nucleo-h743zi \
  && CARGO_TARGET_DIR=$target_dir/nucleo-h743zi cargo build --release --bins \
    -p firmware-testbench --no-default-features --features board-nucleo-h743zi; then
  pass "build nucleo-h743zi"
else
  fail "build nucleo-h743zi"
fi
if CARGO_TARGET_DIR=$target_dir/stm32f407 cargo clippy --release --bins -p firmware \
  -p firmware-testbench --no-default-features --features firmware/board-stm32f407,firmware-testbench/board-stm32f407 -- -D warnings \
  && CARGO_TARGET_DIR=$target_dir/stm32f407 cargo build --release --bins -p firmware \
  -p firmware-testbench --no-default-features --features firmware/board-stm32f407,firmware-testbench/board-stm32f407; then
  pass "build stm32f407 (clippy clean; linked into its 512 KiB code flash and 128 KiB SRAM)"
else
  fail "build stm32f407"
fi

# The testbench's recording: the map file and the start-pose record go into the board's map
# flash region (the map from its first byte, the start pose in its last 4 KiB), as a flasher
# would put them.
out_dir=$(dirname "$(ls -t "$elf_dir"/build/firmware-testbench-*/out/recording.rs 2>/dev/null | head -1)")

echo "--> selftest under QEMU"
if [ -x "$elf_dir/selftest" ]; then
  run_qemu "$elf_dir/selftest" "$work/uart0.bin" | tee "$work/selftest.log"
  status=${PIPESTATUS[0]}
  # The test binary's own counts become part of this script's count.
  read -r st_pass st_fail < <(grep -E '^[0-9]+ passed, [0-9]+ failed$' "$work/selftest.log" \
    | tail -1 | sed -E 's/^([0-9]+) passed, ([0-9]+) failed$/\1 \2/')
  if [ "$status" -eq 0 ] && [ -n "${st_pass:-}" ] && [ "${st_fail:-1}" -eq 0 ]; then
    passed=$((passed + st_pass))
  else
    echo "FAILED: selftest (QEMU status $status)"
    failed=$((failed + ${st_fail:-0}))
    [ "${st_fail:-0}" -eq 0 ] && failed=$((failed + 1))
    passed=$((passed + ${st_pass:-0}))
  fi
  # The vehicle port's (UART1) bytes the firmware sent must be the frame it logged.
  logged=$(sed -nE 's/^ *vehicle port frame [0-9]+ bytes: \[(.*)\]$/\1/p' "$work/selftest.log" | tr -d ', ')
  received=$(od -An -v -tx1 "$work/uart0.bin.vehicle" 2>/dev/null | tr -d ' \n')
  if [ -n "$logged" ] && [ "$logged" = "$received" ]; then
    pass "vehicle port (UART1) bytes on the host match the pose frame the firmware sent"
  else
    fail "vehicle port capture '$received' differs from the logged frame '$logged'"
  fi
else
  fail "selftest ELF missing"
fi

echo "--> fault handling under QEMU (a panic and a HardFault must log and exit with failure)"
for check in panic:fault-check-panic HardFault:fault-check-hardfault; do
  what=${check%%:*} elf=$elf_dir/${check#*:}
  QEMU_TIMEOUT_S=60 run_qemu "$elf" "$work/uart0-fault.bin" >"$work/fault.log" 2>&1
  status=$?
  cat "$work/fault.log"
  if [ "$status" -eq 1 ] && grep -q "$what" "$work/fault.log"; then
    pass "$what logs and exits QEMU with failure"
  else
    fail "$what handling (QEMU status $status; 124 = hung until the time-out)"
  fi
done

echo "--> benchmark under QEMU (instructions per scan, budget check)"
if [ -x "$elf_dir/bench" ]; then
  run_qemu "$elf_dir/bench" "$work/uart0-bench.bin" | tee "$work/bench.log"
  status=${PIPESTATUS[0]}
  if [ "$status" -eq 0 ] && grep -q '^budget PASS' "$work/bench.log" \
    && grep -q '^ram PASS' "$work/bench.log"; then
    pass "bench within the instruction and RAM budgets"
  elif [ "$FW_BUDGET_ENFORCE" = 0 ] && grep -q '^budget FAIL' "$work/bench.log" \
    && ! grep -qE '^FAIL:|panic|HardFault' "$work/bench.log"; then
    echo "WARNING: instruction budget exceeded (not enforced: FW_BUDGET_ENFORCE=0)"
    pass "bench ran (budget not enforced)"
  else
    fail "bench (QEMU status $status; see the budget and FAIL lines above)"
  fi
else
  fail "bench ELF missing"
fi

echo "--> benchmark against the same tunnel's 1 km and 10 km map images (same RAM)"
for long_map in map_1km.bin map_10km.bin; do
  if [ -x "$elf_dir/bench" ] && [ -f "$out_dir/$long_map" ]; then
    QEMU_MAP=$long_map run_qemu "$elf_dir/bench" "$work/uart0-bench.bin" >"$work/bench-long.log"
    status=$?
    grep -E '^(map:|ram|budget|stage end-to-end|localizer:)' "$work/bench-long.log"
    if [ "$status" -eq 0 ] && grep -q '^budget PASS' "$work/bench-long.log" \
      && grep -q '^ram PASS' "$work/bench-long.log"; then
      pass "bench on $long_map within the instruction and RAM budgets"
    else
      fail "bench on $long_map (QEMU status $status)"
    fi
  else
    fail "bench ELF or $long_map missing"
  fi
done

echo "--> controller under QEMU against the LMS5xx emulator (hardware-in-the-loop)"
echo "    (no -icount in this run: the per-scan counts it logs follow QEMU's clock, not the"
echo "     instructions executed; the instruction budget is the bench's, above)"
# The controller (built to stop after HIL_SCANS scans) runs the LMS start-up sequence over
# UART0, which QEMU connects to lidar-driver's emulator replaying the recorded scans as CoLa-B.
# No -icount here: in icount mode QEMU feeds the UART one byte per main-loop turn, far
# slower than the emulator's 25 Hz; instruction counts come from the bench above.
HIL_SCANS=40
if FW_CONTROLLER_SCANS=$HIL_SCANS cargo build --release --quiet --bin controller; then
  ./controller-vs-emulator.sh "$elf_dir/controller" "$work/controller.log"
  status=$?
  cat "$work/controller.log"
  tracking=$(grep -c ') Tracking in' "$work/controller.log")
  echo "controller: $tracking of $HIL_SCANS scans tracking"
  # No odometry here: the first scans' speed is unknown (the recording starts at 10 m/s),
  # their sweep (21 cm) is not carried, their landmarks do not all fit, and the map must be
  # confirmed over 3 m (8 scans at 0.4 m) before a pose is called tracking: 30 of 40.
  if [ "$status" -eq 0 ] && [ "$tracking" -ge $((HIL_SCANS * 3 / 4)) ]; then
    pass "controller localised $HIL_SCANS emulated LMS511 scans over UART0"
  else
    fail "controller against the emulator (status $status, $tracking tracking)"
  fi
  # No odometry wired in this run (UART1 unconnected): it must say it predicts with
  # constant velocity, on every pose frame.
  if grep -q 'odometry: none within' "$work/controller.log" \
    && [ "$(grep -c 'motion ConstantVelocity' "$work/controller.log")" -eq "$HIL_SCANS" ]; then
    pass "controller without odometry says so and predicts with constant velocity"
  else
    fail "controller without odometry: no constant-velocity fallback reported"
  fi
  # Its RAM over that run, session buffer included: static + stack high-water mark.
  ram=$(sed -nE 's/.*= ([0-9]+) bytes \(headroom left: true\).*/\1/p' "$work/controller.log" | tail -1)
  if [ -n "$ram" ] && [ "$ram" -le $((96 * 1024)) ]; then
    pass "controller RAM $ram bytes <= 96 KiB (static + stack high-water mark)"
  else
    fail "controller RAM '${ram:-not reported}' bytes over 96 KiB or not measured"
  fi
else
  fail "build of the controller"
fi

echo "--> watchdog: a stall after 10 scans is reset by the CMSDK watchdog and the controller resumes"
# Built to hang once after 10 scans (FW_STALL_AFTER_SCANS) and to stop after 30 scans of the
# run after the reset. The emulator keeps streaming through the stall, as a scanner on a
# serial line would.
if FW_CONTROLLER_SCANS=30 FW_STALL_AFTER_SCANS=10 cargo build --release --quiet --bin controller; then
  QEMU_TIMEOUT_S=120 ./controller-vs-emulator.sh "$elf_dir/controller" "$work/watchdog.log"
  status=$?
  grep -vE 'skipped unrelated|^INFO  scan [0-9]+:' "$work/watchdog.log"
  after=$(sed -n '/restarted after a reset/,$p' "$work/watchdog.log")
  flagged=$(grep -c 'after reset true' <<<"$after")
  if [ "$status" -eq 0 ] && grep -q 'stalling after 10 scans' "$work/watchdog.log" \
    && grep -q 'restarted after a reset while running (reset 1)' <<<"$after" \
    && grep -q 'subscribed: scans follow' <<<"$after" && [ "$flagged" -ge 1 ] \
    && grep -q 'the pose is stale' "$work/watchdog.log"; then
    pass "stall caught by the watchdog: reset, scanner session re-initialised, 30 scans localised after it ($flagged marked after_reset), stale pose reported while no scan came"
  else
    fail "watchdog (status $status; $flagged poses marked after_reset)"
  fi
else
  fail "build of the stalling controller"
fi
echo "--> host-sim hil: the simulator drives the controller in simulated time (CoLa-B and CoLa-A)"
# The product build (no scan limit, no stall), as host-sim hil runs it.
if cargo build --release --quiet --bin controller \
  && (cd .. && cargo build --release --quiet -p host-sim --bin host-sim); then
  hil() { QEMU_TIMEOUT_S=300 timeout 600 ../target/release/host-sim hil --seed 7 --json --elf "${hil_elf:-$elf_dir/controller}" "$@"; }
  field() { python3 -c "import json,sys; print(json.load(sys.stdin)['$1'])"; }
  for dialect in b a; do
    # CoLa-A telegrams are twice as long: a shorter drive keeps the test quick.
    extra=(); [ "$dialect" = a ] && extra=(--length 4)
    run_rms=$(cd .. && target/release/host-sim run --scenario paper-10m --landmarks p1 --seed 7 \
      "${extra[@]}" --json --quiet | field position_rms_m)
    json=$(hil --scenario paper-10m --landmarks p1 --dialect "$dialect" "${extra[@]}")
    status=$?
    rms=$(field position_rms_m <<<"$json" 2>/dev/null)
    imax=$(field instructions_per_scan_max <<<"$json" 2>/dev/null)
    echo "hil CoLa-$dialect: position RMS ${rms:-?} m (host-sim run: $run_rms m), instructions per scan max ${imax:-?}"
    # The instruction budget is CoLa-B's (the LMS511's streaming dialect); CoLa-A's ASCII
    # values cost ~150 k more per scan and are reported.
    budget=1500000; [ "$dialect" = a ] && budget=2000000
    if [ "$status" -eq 0 ] && [ -n "$rms" ] && [ -n "$imax" ] && [ "$imax" -le "$budget" ] \
      && python3 -c "import sys; sys.exit(0 if abs($rms - $run_rms) <= 1e-3 else 1)"; then
      pass "host-sim hil in CoLa-$dialect: the firmware's poses scored like run's${extra[*]:+ (4 m)}"
    else
      fail "host-sim hil in CoLa-$dialect (status $status): ${json:0:300}"
    fi
  done
  # A 75 Hz drive: the emulated scanner must send the scans as recorded (0.5°), and the
  # vehicle's odometry frames must carry the pose at each scan's time, as replay predicts it
  # (75 Hz scans between 100 Hz readings). Set up at its power-up 25 Hz and 1/6° the
  # emulator once reshaped 50 Hz scans onto twice the beams at angles up to 1/12° off (the
  # firmware scored 6.3 mm on 4 m at 50 Hz against run's 2.5 mm); the same scans and the
  # same odometry give the same poses to the micrometre.
  # `like_run LABEL PASS-TEXT ARGS…`: paper-10m (P1, seed 7) under hil with ARGS must score
  # like `host-sim run` with them, to 0.05 mm, within the instruction budget.
  like_run() {
    local label=$1 what=$2; shift 2
    run_rms=$(cd .. && target/release/host-sim run --scenario paper-10m --landmarks p1 --seed 7 \
      "$@" --json --quiet | field position_rms_m)
    json=$(hil --scenario paper-10m --landmarks p1 "$@")
    status=$?
    rms=$(field position_rms_m <<<"$json" 2>/dev/null)
    imax=$(field instructions_per_scan_max <<<"$json" 2>/dev/null)
    echo "hil $label: position RMS ${rms:-?} m (host-sim run: $run_rms m), instructions per scan max ${imax:-?}"
    if [ "$status" -eq 0 ] && [ -n "$rms" ] && [ -n "$imax" ] && [ "$imax" -le 1500000 ] \
      && python3 -c "import sys; sys.exit(0 if abs($rms - $run_rms) <= 5e-5 else 1)"; then
      pass "host-sim hil $label: $what (4 m)"
    else
      fail "host-sim hil $label (status $status): ${json:0:300}"
    fi
  }
  like_run "at 75 Hz" "the scans and the odometry at their times reach the firmware as recorded (its poses scored like run's)" \
    --rate 75 --length 4
  # The scanner's sweep (`--sweep`): each beam taken from where the vehicle was when the
  # mirror passed it, as a real LMS511 takes it; the firmware carries each echo to the
  # scan's last beam (loc-core's de-skew, the speed from its own track, the telegrams' µs
  # stamps) and must score like run, which de-skews on the host (without the de-skew,
  # paper-10m seed 1 scored 10.5 mm; with it 2.4 mm, 2.5 mm without the sweep).
  like_run "with the sweep" "the firmware de-skews the scans as run does" --sweep --length 4
  echo "--> host-sim hil with a stall: the watchdog resets the controller mid-drive, it bridges the outage by odometry and tracks on"
  # Built to hang once after 40 scans; the product is built again for the tests after. The
  # vehicle drives on for 1.5 s while the controller restarts (host-sim hil's default
  # outage): ~4 m on tunnel-1km, beyond the 1 m a start from the last pose alone allows.
  if FW_STALL_AFTER_SCANS=40 cargo build --release --quiet --bin controller \
    && cp "$elf_dir/controller" "$work/controller-stall" \
    && cargo build --release --quiet --bin controller; then
    json=$(hil_elf="$work/controller-stall" hil --scenario tunnel-1km --landmarks p1 --length 30 --out "$work/hil-stall")
    status=$?
    restarts=$(field restarts <<<"$json" 2>/dev/null)
    rms=$(field position_rms_m <<<"$json" 2>/dev/null)
    bridged=$(defmt-print -e "$work/controller-stall" <"$work/hil-stall/firmware.defmt" 2>/dev/null | grep -m1 "outage bridged")
    echo "hil with a stall: restarts ${restarts:-?}, position RMS ${rms:-?} m; ${bridged:-no bridge logged}"
    if [ "$status" -eq 0 ] && [ -n "$bridged" ] \
      && python3 -c "import sys; r=$restarts; sys.exit(0 if len(r) == 1 and r[0]['first_lost_scan'] == 40 and r[0]['scans_to_tracking'] == 1 else 1)" \
      && python3 -c "import sys; sys.exit(0 if $rms <= 0.008 else 1)"; then
      pass "stall under hil: watchdog reset at scan 40, $(python3 -c "print($restarts[0]['lost_scans'])") scans lost to the outage, tracking on the first scan after it (odometry bridge), position RMS $rms m"
    else
      fail "host-sim hil with a stall (status $status): ${json:0:300}"
    fi
  else
    fail "build of the stalling controller for the HIL run"
  fi
else
  fail "build of the controller or host-sim for the HIL run"
fi

echo "--> controller without a map (erased map flash region): reports it and waits"
timeout 8 qemu-system-arm -machine mps2-an386 -nographic \
  -semihosting-config enable=on,target=native \
  -serial "file:$work/uart0-nomap.bin" -serial "file:$work/uart1-nomap.bin" \
  -kernel "$elf_dir/controller" >"$work/raw.defmt"
status=$?
defmt-print -e "$elf_dir/controller" <"$work/raw.defmt" | tee "$work/nomap.log"
frames=$(od -An -v -tx1 "$work/uart1-nomap.bin" 2>/dev/null | tr ' ' '\n' | grep -c '^00$')
if [ "$status" -eq 124 ] && grep -q 'no usable map' "$work/nomap.log" && [ "$frames" -ge 2 ]; then
  pass "controller without a map waits, logs it and sends NoMap frames ($frames)"
else
  fail "controller without a map (QEMU status $status, 124 = still waiting; $frames frames)"
fi

echo
outcome=ok
[ "$failed" -gt 0 ] && outcome=FAILED
echo "test result: $outcome. $passed passed; $failed failed; 0 ignored (firmware under QEMU)"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
