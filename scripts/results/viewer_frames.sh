#!/usr/bin/env bash
# Frame times of `host view` at 1280x720 on the default cloud, in a virtual X server (Xvfb), and
# the README's picture of the window (split view with the HUD). Machine-exclusive timings.
#
# usage: scripts/results/viewer_frames.sh HOST OUT_DIR [BACKEND]   (BACKEND: gpu (default) or cpu)
set -euo pipefail
host="$1"; out="$2"; backend="${3:-gpu}"
mkdir -p "$out/fb"
display=":$((500 + $$ % 400))"
Xvfb "$display" -screen 0 1280x720x24 -fbdir "$out/fb" -nolisten tcp >/dev/null 2>&1 &
xvfb=$!
trap 'kill $xvfb 2>/dev/null || true' EXIT
sleep 1
export DISPLAY="$display"
run() { # name, extra flags...
  local name="$1"; shift
  "$host" view --width 1280 --height 720 --max-spp 16 --frame-spp 1 --backend "$backend" \
    --save-dir "$out/shots" "$@" > "$out/$name.log" 2>&1 &
  local pid=$!
  for _ in $(seq 1 1200); do grep -q "reached 16 spp" "$out/$name.log" && break; sleep 0.5; done
  grep "reached" "$out/$name.log" | tail -1 | sed "s/^/$name: /"
  if [ "$name" = picture ]; then
    win=$(xdotool search --name "host view" | head -1)
    xdotool windowfocus --sync "$win"
    xdotool key b
    for _ in $(seq 1 1200); do [ "$(grep -c 'reached 16 spp' "$out/$name.log")" -ge 2 ] && break; sleep 0.5; done
    grep "reached" "$out/$name.log" | tail -1 | sed "s/^/$name (split): /"
    cp "$out/fb/Xvfb_screen0" "$out/screen.xwd"
    python3 "$(dirname "$0")/xwd_to_png.py" "$out/screen.xwd" "$out/viewer.png" 1280 720
  fi
  kill "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
}
run jackknife --estimator jackknife
run track-length --estimator track-length
run ratio --estimator ratio
run direct --integrator direct --exposure 0.35
run picture --estimator jackknife
