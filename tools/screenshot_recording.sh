#!/usr/bin/env bash
# Screenshot of a handover recording in the real Rerun viewer, on a machine without display or GPU.
#
#   tools/screenshot_recording.sh RECORDING.rrd [OUTPUT.png] [WIDTHxHEIGHT]
#
# Runs the Rerun viewer (the `rerun` of the project's venv) under a private Xvfb display with
# Mesa's software Vulkan (llvmpipe), with the recorder's blueprint set to follow the newest
# data (so the 3-D view shows the end of the run), and uses the viewer's own
# `--screenshot-to`. The viewer listens on 127.0.0.1 only, on a free port, with its usage
# analytics disabled in a private configuration folder.
# The viewer takes its picture after a few frames, not when it has read the whole file: the
# recorder's file (thousands of small chunks, no footer) is first compacted with
# `rerun rrd optimize` into a temporary copy (~500 chunks), which the viewer reads in time;
# otherwise entities whose chunks were not read yet (the skeleton, the hands) are missing.
# Needs (Debian): xvfb mesa-vulkan-drivers libvulkan1  — apt-get install -y xvfb mesa-vulkan-drivers
# Takes 20–60 s on two cores (software rendering, Baxter's meshes).
set -euo pipefail

usage() { echo "usage: $0 RECORDING.rrd [OUTPUT.png] [WIDTHxHEIGHT]" >&2; exit 2; }
[[ $# -ge 1 && $# -le 3 ]] || usage
recording=$1
output=${2:-docs/img/rerun_handover.png}
size=${3:-1600x1000}
[[ -f $recording ]] || { echo "error: recording $recording does not exist" >&2; exit 2; }
[[ $output == *.png ]] || { echo "error: output $output must end in .png" >&2; exit 2; }
[[ $size =~ ^[0-9]+x[0-9]+$ ]] || { echo "error: size $size must look like 1600x1000" >&2; exit 2; }

root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-$root/.venv/bin/python}
rerun_cli=${RERUN:-$root/.venv/bin/rerun}
command -v Xvfb >/dev/null || { echo "error: Xvfb not found: apt-get install -y xvfb mesa-vulkan-drivers" >&2; exit 1; }
[[ -x $rerun_cli ]] || { echo "error: $rerun_cli not found: install the project (.venv)" >&2; exit 1; }
ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 \
  || { echo "error: no software Vulkan driver: apt-get install -y mesa-vulkan-drivers" >&2; exit 1; }

work=$(mktemp -d)
xvfb_pid=""
cleanup() {
  if [[ -n $xvfb_pid ]]; then kill "$xvfb_pid" 2>/dev/null || true; wait "$xvfb_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

# A private X display (its number chosen by Xvfb), no TCP listener.
width=${size%x*}; height=${size#*x}
Xvfb -displayfd 3 -nolisten tcp -screen 0 "$((width * 2))x$((height * 2))x24" 3>"$work/display" 2>"$work/xvfb.log" &
xvfb_pid=$!
for _ in $(seq 50); do [[ -s $work/display ]] && break; sleep 0.1; done
[[ -s $work/display ]] || { echo "error: Xvfb did not start: $(cat "$work/xvfb.log")" >&2; exit 1; }
display=":$(cat "$work/display")"

# The recorder's blueprint, with the time cursor at the end of the recording.
"$python" - "$work/handover.rbl" <<'EOF'
import sys
from services.recorder.blueprint import blueprint
blueprint("baxter", follow_latest=True).save("handover", sys.argv[1])
EOF

# A compact copy of the recording (the original is not touched).
if ! "$rerun_cli" rrd optimize "$recording" -o "$work/compact.rrd" >"$work/optimize.log" 2>&1; then
  echo "error: rerun rrd optimize failed; its output:" >&2
  tail -5 "$work/optimize.log" >&2
  exit 1
fi

mkdir -p "$(dirname "$output")"
rm -f "$output"
mkdir -m 700 "$work/xdg" "$work/config" "$work/data"
# The viewer's usage analytics (on by default in a user's ~/.config/rerun) stay off: a private
# configuration folder with them disabled, so the viewer sends nothing off this machine.
export XDG_CONFIG_HOME=$work/config XDG_DATA_HOME=$work/data
"$rerun_cli" analytics disable >/dev/null 2>&1 \
  || { echo "error: could not disable the viewer's analytics in $work/config" >&2; exit 1; }
if ! DISPLAY=$display XDG_RUNTIME_DIR=$work/xdg WGPU_BACKEND=vulkan RUST_LOG=error \
     timeout 300 "$rerun_cli" --bind 127.0.0.1 --port auto --window-size "$size" \
     --screenshot-to "$output" "$work/compact.rrd" "$work/handover.rbl" >"$work/viewer.log" 2>&1; then
  echo "error: the Rerun viewer failed; its output:" >&2
  tail -20 "$work/viewer.log" >&2
  exit 1
fi
[[ -s $output ]] || { echo "error: no screenshot written; viewer output:" >&2; tail -20 "$work/viewer.log" >&2; exit 1; }
echo "screenshot: $output ($(identify -format '%wx%h' "$output" 2>/dev/null || echo "?") px) of $recording"
