#!/usr/bin/env bash
# Makes docs/qmodmaster.png, the README's picture of QModMaster polling the virtual Uno:
# builds QModMaster from its public source with Debian's Qt 5, runs `make serve
# EXAMPLE=uno_slave`, drives QModMaster on a virtual X display (Xvfb, xdotool) the way the
# README's "Polling from QModMaster" tells a user to, and photographs it (ImageMagick).
#
#   docs/qmodmaster-screenshot.sh [SOURCE]
#
# SOURCE is QModMaster 0.4.7's source: a folder holding qModMaster.pro, a .zip or .tar.*
# of it (SourceForge's release archive), or a git repository (a URL or a local clone);
# by default https://github.com/zhanglongqi/qModMaster, a git copy of 0.4.7. Nothing of
# it is kept in this repository: it is unpacked and built under target/qmodmaster/.
#
# Not part of `make test`: QModMaster is not packaged in Debian. Needs /tmp/ttyUNO free
# (no other `make serve` running). On Debian, missing packages are installed.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

source_arg=${1:-https://github.com/zhanglongqi/qModMaster}
work=$root/target/qmodmaster
out=$root/docs/qmodmaster.png
port=/tmp/ttyUNO

say() { printf 'qmodmaster-screenshot: %s\n' "$*" >&2; }
die() { say "$*"; exit 1; }

# --- Tools -------------------------------------------------------------------------------
debian_packages=(qtbase5-dev qt5-qmake g++ make git unzip xvfb xdotool imagemagick fonts-dejavu-core)
missing=()
for p in "${debian_packages[@]}"; do
  dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null | grep -qx installed || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  if [ -r /etc/os-release ] && grep -q '^ID=debian' /etc/os-release; then
    say "installing ${missing[*]}"
    if [ "$(id -u)" = 0 ]; then sudo=(); else sudo=(sudo); fi
    "${sudo[@]}" apt-get update -qq
    DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    die "install Qt 5's qmake and headers, a C++ compiler, make, git, unzip, Xvfb, xdotool, ImageMagick and the DejaVu fonts (Debian: ${debian_packages[*]})"
  fi
fi
qmake=/usr/lib/qt5/bin/qmake
[ -x "$qmake" ] || qmake=$(command -v qmake) || die "no qmake"

# --- QModMaster, from source ---------------------------------------------------------------
mkdir -p "$work"
src=$work/src
if [ -d "$source_arg" ] && [ -f "$source_arg/qModMaster.pro" ]; then
  src=$(cd "$source_arg" && pwd)
elif [ -f "$src/qModMaster.pro" ] && [ "$(cat "$work/source" 2>/dev/null)" = "$source_arg" ]; then
  say "using $src, unpacked from $source_arg before"
else
  rm -rf "$src" "$work/unpack"
  mkdir -p "$work/unpack"
  case $source_arg in
    *.zip) unzip -q "$source_arg" -d "$work/unpack" ;;
    *.tar | *.tar.*) tar -xf "$source_arg" -C "$work/unpack" ;;
    *)
      say "cloning $source_arg"
      git clone -q --depth 1 "$source_arg" "$work/unpack/qModMaster" 2>/dev/null ||
        { rm -rf "$work/unpack/qModMaster" && git clone -q "$source_arg" "$work/unpack/qModMaster"; } ||
        die "could not clone $source_arg"
      ;;
  esac
  pro=$(find "$work/unpack" -name qModMaster.pro -print -quit)
  [ -n "$pro" ] || die "no qModMaster.pro in $source_arg"
  mv "$(dirname "$pro")" "$src"
  rm -rf "$work/unpack"
  printf '%s\n' "$source_arg" >"$work/source"
fi
version=$(sed -n 's/.*VER = "\(QModMaster [^"]*\)".*/\1/p' "$src/forms/about.cpp")
[ "$version" = "QModMaster 0.4.7" ] || say "this is ${version:-an unknown version}; the README describes QModMaster 0.4.7"
say "building ${version:-QModMaster} with $("$qmake" -query QT_VERSION | sed 's/^/Qt /')"
mkdir -p "$work/build"
(cd "$work/build" && "$qmake" "$src/qModMaster.pro" >/dev/null && make -s -j"$(nproc)" >/dev/null 2>"$work/build.log") ||
  die "QModMaster did not build: see $work/build.log"
app=$work/build/qModMaster

# --- Processes, stopped on exit -----------------------------------------------------------
pids=()
cleanup() {
  local p
  for p in "${pids[@]}"; do kill -- "-$p" 2>/dev/null || kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT
# Starts "$@" in a process group of its own, so that stopping it stops its children too.
start() { setsid "$@" & pids+=($!); }
# wait_for SECONDS FILE GREP-ARGUMENTS: waits until grep finds them in FILE.
wait_for() {
  local i seconds=$1 file=$2
  shift 2
  for ((i = 0; i < seconds * 10; i++)); do grep -q "$@" -- "$file" 2>/dev/null && return 0; sleep 0.1; done
  return 1
}

# The virtual Uno.
[ ! -e "$port" ] || die "$port exists: stop the make serve that made it"
start make -s serve EXAMPLE=uno_slave </dev/null >"$work/serve.log" 2>&1
wait_for 900 "$work/serve.log" -e '^serial: 19200 8E1' || die "make serve did not start: see $work/serve.log"

# The display: Xvfb picks a free number.
start Xvfb -displayfd 3 -screen 0 1300x800x24 -nolisten tcp 3>"$work/display" 2>"$work/xvfb.log"
wait_for 10 "$work/display" -e '[0-9]' || die "Xvfb did not start: see $work/xvfb.log"
export DISPLAY=:$(head -n 1 "$work/display")

# QModMaster keeps its settings in qModMaster.ini in the folder it runs in: a fresh one.
run=$work/run
rm -rf "$run"
mkdir -p "$run"
start env -C "$run" LANG=C.UTF-8 LC_ALL=C.UTF-8 XDG_RUNTIME_DIR="$run" "$app" >"$run/app.log" 2>&1
main=$(timeout 20 xdotool search --sync --name '^Modbus Master$' | sed -n 1p) || die "QModMaster did not open"
xdotool windowsize "$main" 640 400
sleep 1

# Clicks at x y in the main window (no window manager: it sits at 0,0, no frame); places
# found for 640x400 with the DejaVu fonts.
click() { xdotool mousemove "$1" "$2" click 1; sleep 0.3; }
field() { click "$1" "$2"; xdotool key ctrl+a type "$3"; sleep 0.3; }
toolbar_connect=(29 42) toolbar_read_write=(63 42) toolbar_bus_monitor=(240 42) toolbar_rtu=(281 42)
function_code=(235 126) start_address=(200 157) number=(530 157)

# Options > Modbus RTU: the port typed in, then 19200, 8, 1, Even, RTS None, as make serve
# prints them (the lists are chosen with Home/Down: baud 19200 is the ninth entry).
click "${toolbar_rtu[@]}"
timeout 10 xdotool search --sync --name '^Modbus RTU Settings$' >/dev/null || die "no Modbus RTU dialog"
xdotool key ctrl+a type "$port"
xdotool key Tab Home Down Down Down Down Down Down Down Down \
  Tab Home Down Tab Home Tab Home Down Down Tab Home Return
for setting in "SerialPort=$port" Baud=19200 DataBits=8 StopBits=1 Parity=Even; do
  wait_for 5 "$run/qModMaster.ini" -xF "$setting" || die "the RTU dialog did not take $setting: see $run/qModMaster.ini"
done

# The bus monitor records only while it is open: opened first, under the main window.
click "${toolbar_bus_monitor[@]}"
monitor=$(timeout 10 xdotool search --sync --name '^Bus Monitor$' | sed -n 1p) || die "no bus monitor"
xdotool windowmove "$monitor" 0 420 windowsize "$monitor" 1280 300
sleep 0.5

click "${toolbar_connect[@]}"
wait_for 5 "$run/app.log" -F "Connecting to Serial Port [$port]...OK" || die "QModMaster did not connect: see $run/app.log"

# Read Holding Registers (0x03), Start Address 0, 10 registers: 40001-40010.
click "${function_code[@]}"
xdotool key Down Down Return
sleep 0.3
field "${number[@]}" 10
click "${toolbar_read_write[@]}"
wait_for 5 "$run/app.log" -F '01  03  00  00  00  0a  c5  cd' &&
  wait_for 5 "$run/app.log" -F 'Modbus Read Data return value =  10' || die "the read of 40001-40010 failed: see $run/app.log"
sleep 0.5
import -window "$main" "$work/read.png"

# Start Address 1, 10 registers: 40002-40011; uno_slave has no 40011, exception 02.
field "${start_address[@]}" 1
click "${toolbar_read_write[@]}"
wait_for 5 "$run/app.log" -F '01  03  00  01  00  0a  94  0d' &&
  wait_for 5 "$run/app.log" -F 'System exception. [Illegal data address]' || die "no exception 02 for 40002-40011: see $run/app.log"
sleep 0.5
import -window "$main" "$work/exception.png"
import -window "$monitor" "$work/monitor.png"

# One picture: the two states side by side, each under a line saying what it is, and the
# bus monitor's list of frames below them.
label() {
  convert -background '#30343a' -fill white -font DejaVu-Sans -pointsize 13 -size "$1x24" -gravity west \
    label:"  $2" "$3"
}
label 640 "Start Address 0, Number of Registers 10: reads 40001-40010" "$work/read-label.png"
label 640 "Start Address 1, Number of Registers 10: 40002-40011, exception 02" "$work/exception-label.png"
label 1288 "Bus Monitor: the two requests and their replies on the wire" "$work/frames-label.png"
convert \( "$work/read-label.png" "$work/read.png" -append \) -size 8x424 xc:'#30343a' \
  \( "$work/exception-label.png" "$work/exception.png" -append \) +append "$work/top.png"
convert "$work/monitor.png" -crop 1280x97+0+71 +repage -background white -gravity west -extent 1288x97 "$work/frames.png"
convert "$work/top.png" "$work/frames-label.png" "$work/frames.png" -append +dither -colors 48 -strip \
  -define png:compression-level=9 "PNG8:$out"
say "wrote $out ($(stat -c %s "$out") bytes)"
