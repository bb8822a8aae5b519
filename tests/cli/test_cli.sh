#!/usr/bin/env bash
# Command-line contract of relief and reliefd: versions agree, usage errors exit 2 with a
# message naming the problem, --help exits 0.
set -u
relief=$1 reliefd=$2 data=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0 passes=0
check() { # name expected_status command...
	local name=$1 want=$2; shift 2
	local out status
	out=$("$@" 2>&1); status=$?
	if [ "$status" -ne "$want" ]; then
		echo "FAIL $name: exit $status, expected $want; output: $out"; fails=$((fails + 1))
	else
		passes=$((passes + 1))
	fi
	LAST_OUT=$out
}
# Vulkan-using commands: the loader unloads the driver before exit, so LeakSanitizer cannot
# name (or suppress) the driver's exit-time allocations. Leaks in relief's own code on these
# paths are checked by the GPU tests, which create and destroy the same objects with the
# driver pinned (tests/gpu/gpu_test.h).
vkcheck() { # like check, leak detection off
	ASAN_OPTIONS="${ASAN_OPTIONS:-}:detect_leaks=0" check "$@"
}
expect_text() { # name text
	if ! grep -qF -- "$2" <<<"$LAST_OUT"; then
		echo "FAIL $1: output lacks '$2': $LAST_OUT"; fails=$((fails + 1))
	else
		passes=$((passes + 1))
	fi
}
check relief-version 0 "$relief" --version
rv=$LAST_OUT
check reliefd-version 0 "$reliefd" --version
dv=$LAST_OUT
if [ "${rv#relief }" != "${dv#reliefd }" ] || [ -z "${rv#relief }" ]; then
	echo "FAIL versions differ: '$rv' vs '$dv'"; fails=$((fails + 1))
fi
check relief-help 0 "$relief" --help
expect_text relief-help-lists-hello "hello"
check relief-no-args 2 "$relief"
check relief-version-extra 2 "$relief" --version extra
expect_text relief-version-extra-named "--version takes nothing after it (got 'extra')"
RELIEF_LOG=verbose check relief-bad-log 0 "$relief" --version
expect_text relief-bad-log-named "RELIEF_LOG='verbose' is not error, warn, info or debug"
check relief-unknown-command 2 "$relief" frobnicate
expect_text relief-unknown-command-named "'frobnicate' is not a command"
check relief-hello-help 0 "$relief" hello --help
check relief-hello-unknown-option 2 "$relief" hello --bogus
expect_text relief-hello-unknown-option-named "unknown option '--bogus'"
check relief-hello-bad-size 2 "$relief" hello --size 0x10
expect_text relief-hello-bad-size-named "--size"
check relief-hello-missing-value 2 "$relief" hello --size
check reliefd-unknown-option 2 "$reliefd" --bogus
check reliefd-bad-config 1 "$reliefd" --config /nonexistent.conf --check
expect_text reliefd-bad-config-named "/nonexistent.conf"

# pack / info / unpack on real data
check pack-lux 0 "$relief" pack "$data/luxembourg_elev.tif" "$tmp/lux.relief" --tolerance 1 --patch 65
expect_text pack-summary "measured max error"
check pack-quiet 0 "$relief" pack "$data/ps_height_1k.png" "$tmp/ps.relief" -t 4 -q
[ -z "$LAST_OUT" ] || { echo "FAIL pack -q printed: $LAST_OUT"; fails=$((fails + 1)); }
check info 0 "$relief" info "$tmp/lux.relief"
expect_text info-extent "extent"
expect_text info-crs "+proj=eqc"
check info-json 0 "$relief" info "$tmp/ps.relief" --json
expect_text info-json-levels '"levels":[{"level":0'
# the block error codes' unit: tolerance / 64 at 4 m (the largest error, ~2,600 m, fits)
expect_text info-json-unit '"block_error_unit_m":0.0625,'
# the format version: the current one, or 8 on request for older readers; others refused
expect_text info-json-version '"version":9,'
# Blocks with a valid sample (what a renderer tessellates): all of Puget Sound's, not all of
# Luxembourg's (no-data outside the border, padding beside it).
blocks_ok() { # name want(all|some) json
	local pairs
	pairs=$(grep -o '"blocks":[0-9]*,"blocks_with_data":[0-9]*' <<<"$3" | sed 's/[^0-9,]//g')
	if [ -n "$pairs" ] && awk -F, -v want="$2" '{ all += $1; data += $2; if ($2 > $1) bad = 1 }
		END { exit !(!bad && all > 0 && (want == "all" ? data == all : data < all && data > 0)) }' <<<"$pairs"; then
		passes=$((passes + 1))
	else
		echo "FAIL $1: blocks and blocks with data per level: $pairs"; fails=$((fails + 1))
	fi
}
blocks_ok info-json-blocks-puget all "$LAST_OUT"
check info-json-lux 0 "$relief" info "$tmp/lux.relief" --json
blocks_ok info-json-blocks-lux some "$LAST_OUT"
expect_text info-json-drawn '"err_max_m":'
expect_text info-json-drawn '"drawn_err_max_m":'
check pack-format-8 0 "$relief" pack "$data/luxembourg_elev.tif" "$tmp/lux8.relief" -t 1 --format-version 8 -q
check info-format-8 0 "$relief" info "$tmp/lux8.relief"
expect_text info-format-8-named "relief format 8,"
check pack-format-7 2 "$relief" pack "$data/luxembourg_elev.tif" "$tmp/lux7.relief" -t 1 --format-version 7
expect_text pack-format-7-named "--format-version: '7' is not a whole number in [8, 9]"
# A version-6 file has no drawn error: info says it shows the bound from Err(P).
check info-v6 0 "$relief" info "$data/alps-crop-140x100-v6.relief"
expect_text info-v6-bound "format 6 stores no E0(P)"
check unpack-raw 0 "$relief" unpack "$tmp/lux.relief" "$tmp/lux.f32" --raw --mask "$tmp/lux.mask"
[ "$(stat -c %s "$tmp/lux.f32")" -eq $((95 * 90 * 4)) ] || { echo "FAIL raw size"; fails=$((fails + 1)); }
[ "$(stat -c %s "$tmp/lux.mask")" -eq $((95 * 90)) ] || { echo "FAIL mask size"; fails=$((fails + 1)); }
check unpack-level 0 "$relief" unpack "$tmp/lux.relief" "$tmp/lux0.f32" --raw --level 0
[ "$(stat -c %s "$tmp/lux0.f32")" -eq $((48 * 45 * 4)) ] || { echo "FAIL level-0 size"; fails=$((fails + 1)); }
check unpack-bad-level 2 "$relief" unpack "$tmp/lux.relief" "$tmp/x.f32" --level 9
expect_text unpack-bad-level-named "levels 0..1"
# An output that is an input under any name is refused before anything is written (pack
# once replaced its input raster, unpack its .relief file); the input stays as it was.
cp "$data/luxembourg_elev.tif" "$tmp/own.tif"
ln -s "$tmp/own.tif" "$tmp/own-link.tif"
sum_before=$(md5sum <"$tmp/own.tif")
check pack-onto-input 2 "$relief" pack "$tmp/own.tif" "$tmp/own-link.tif" -t 1
expect_text pack-onto-input-named "is the input $tmp/own.tif"
printf '[import]\nspacing = 30\n' >"$tmp/own.tif.relief-import"
check pack-onto-sidecar 2 "$relief" pack "$tmp/own.tif" "$tmp/own.tif.relief-import" -t 1
expect_text pack-onto-sidecar-named "is the input $tmp/own.tif.relief-import"
sum_lux=$(md5sum <"$tmp/lux.relief")
check unpack-onto-input 2 "$relief" unpack "$tmp/lux.relief" "$tmp/../$(basename "$tmp")/lux.relief"
check unpack-geotiff 0 "$relief" unpack "$tmp/lux.relief" "$tmp/lux-out.tif" --mask "$tmp/lux-out.mask"
check unpack-mask-onto-output 2 "$relief" unpack "$tmp/lux.relief" "$tmp/u.f32" --raw --mask "$tmp/u.f32"
expect_text unpack-mask-onto-output-named "are one file"
[ "$(md5sum <"$tmp/own.tif")" = "$sum_before" ] && [ "$(md5sum <"$tmp/lux.relief")" = "$sum_lux" ] ||
	{ echo "FAIL an input changed"; fails=$((fails + 1)); }
[ -z "$(ls "$tmp" | grep '\.tmp')" ] || { echo "FAIL temporary files left: $(ls "$tmp")"; fails=$((fails + 1)); }
# usage errors
check pack-no-tolerance 2 "$relief" pack "$data/luxembourg_elev.tif" "$tmp/x.relief"
expect_text pack-no-tolerance-named "--tolerance"
check pack-bad-patch 2 "$relief" pack "$data/luxembourg_elev.tif" "$tmp/x.relief" -t 1 --patch 100
check pack-bad-tolerance 2 "$relief" pack "$data/luxembourg_elev.tif" "$tmp/x.relief" -t nan
check pack-zero-spacing 2 "$relief" pack "$data/alps-montblanc.png" "$tmp/x.relief" -t 1 --spacing 0
cp "$data/alps-montblanc.png" "$tmp/nosidecar.png"
check pack-png-needs-spacing 1 "$relief" pack "$tmp/nosidecar.png" "$tmp/x.relief" -t 1
expect_text pack-png-needs-spacing-named "--spacing"
printf '[import]\nspacing = ten\n' > "$tmp/nosidecar.png.relief-import"
check pack-bad-sidecar 2 "$relief" pack "$tmp/nosidecar.png" "$tmp/x.relief" -t 1
expect_text pack-bad-sidecar-named "spacing"
# Heights that cannot be heights are no-data, and pack says how many and where (even with -q);
# NaN may be named the no-data value, which silences it for NaN. A 3 x 2 float32 raster:
# 100 m, +inf, 100 m / NaN, 100 m, 100 m.
printf '\x00\x00\xc8\x42\x00\x00\x80\x7f\x00\x00\xc8\x42\x00\x00\xc0\x7f\x00\x00\xc8\x42\x00\x00\xc8\x42' >"$tmp/odd.f32"
check pack-impossible 0 "$relief" pack "$tmp/odd.f32" "$tmp/odd.relief" -t 1 -q --raw-size 3x2 --raw-type float32 --spacing 30
expect_text pack-impossible-named "odd.f32: 2 sample(s) not finite or beyond 1e+06 m (one at column 1, row 0) stored as no-data"
check pack-impossible-nan 0 "$relief" pack "$tmp/odd.f32" "$tmp/odd.relief" -t 1 -q --raw-size 3x2 --raw-type float32 --spacing 30 --nodata nan
expect_text pack-impossible-nan-named "odd.f32: 1 sample(s) not finite or beyond 1e+06 m (one at column 1, row 0)"
check bench-codec-impossible 0 "$relief" bench codec "$tmp/odd.f32" --raw-size 3x2 --raw-type float32 --spacing 30 --runs 1
expect_text bench-codec-impossible-named "relief bench codec: $tmp/odd.f32: 2 sample(s) not finite"
check info-impossible 0 "$relief" info "$tmp/odd.relief"
expect_text info-impossible-valid "4 valid samples"
check pack-raw-half 2 "$relief" pack "$data/luxembourg_elev.tif" "$tmp/x.relief" -t 1 --raw-size 4x4
expect_text pack-raw-half-named "--raw-size and --raw-type"
# A raw raster's side is not a viewport's: wider than 16384 samples is accepted (then this
# 24-byte file is the wrong size for it), beyond what a file can hold is not.
check pack-raw-wide 1 "$relief" pack "$tmp/odd.f32" "$tmp/x.relief" -t 1 --raw-size 20000x3 --raw-type float32 --spacing 30
expect_text pack-raw-wide-named "20000x3 float32 samples need 240000"
check pack-raw-too-wide 2 "$relief" pack "$tmp/odd.f32" "$tmp/x.relief" -t 1 --raw-size 4194305x3 --raw-type float32 --spacing 30
expect_text pack-raw-too-wide-named "both in [1, 4194304]"
# A long, narrow raster costs what its data does, not its square quadtree: 262145 x 2
# samples at 65-sample patches make a tree of 22,369,621 patches (13 levels over a
# 262145 x 262145 grid) of which 8,191 lie over the raster; only those have index records
# (format version 6) and per-patch records while packing (about 2 s and 230 MB).
head -c 2097160 /dev/zero >"$tmp/strip262k.f32"
check pack-long-strip 0 "$relief" pack "$tmp/strip262k.f32" "$tmp/strip.relief" -t 1 -q --raw-size 262145x2 \
	--raw-type float32 --spacing 1 --patch 65
check info-long-strip 0 "$relief" info "$tmp/strip.relief"
expect_text info-long-strip-entries "8191 index records"
# and unpacks (the reference decoder keeps the patches with an index entry only: the
# finest level's 16,777,216 patch blocks would take 300 GB)
check unpack-long-strip 0 "$relief" unpack "$tmp/strip.relief" "$tmp/strip-out.f32" --raw
[ "$(stat -c %s "$tmp/strip-out.f32")" -eq 2097160 ] || { echo "FAIL long strip unpacked size"; fails=$((fails + 1)); }
cmp -s "$tmp/strip-out.f32" "$tmp/strip262k.f32" || { echo "FAIL long strip of zeros unpacked"; fails=$((fails + 1)); }
head -c 8388608 /dev/zero >"$tmp/strip.f32"
# A raster whose packing cannot fit in the memory this process may use is refused at once,
# naming it: a 1048576 x 2 strip's levels at 129-sample patches quantise 278,909,516 samples
# (windows 131 samples high at every level), about 1.5 GB estimated, which fits this
# machine but not 1 GB of address space. (Not under a sanitizer, whose shadow memory needs
# more address space than that.) Refusing for want of physical memory is the same
# comparison against the machine's memory; since packing follows the data, no input this
# test could write is that large.
if ldd "$relief" | grep -q 'lib[at]san'; then
	echo "skip pack-address-space, bench-codec-address-space: sanitizer build"
else
	check pack-address-space 1 bash -c 'ulimit -v 1000000 && exec "$@"' sh "$relief" pack "$tmp/strip.f32" \
		"$tmp/x.relief" -t 1 -q --raw-size 1048576x2 --raw-type float32 --spacing 1
	expect_text pack-address-space-named "too large to pack here: this 1048576 x 2 raster makes a quadtree of 89478485 patches (16383 of them over the raster)"
	expect_text pack-address-space-limit "where this process may use 1.0 GB"
	check bench-codec-address-space 1 bash -c 'ulimit -v 1000000 && exec "$@"' sh "$relief" bench codec \
		"$tmp/strip.f32" --raw-size 1048576x2 --raw-type float32 --spacing 1 --runs 1
	expect_text bench-codec-address-space-named "relief bench codec: $tmp/strip.f32: too large to pack here"
fi
# bad input keeps what is already stored
cp "$tmp/lux.relief" "$tmp/keep.relief"
check pack-missing-input 1 "$relief" pack "$tmp/missing.tif" "$tmp/keep.relief" -t 1
expect_text pack-missing-input-named "missing.tif"
cmp -s "$tmp/lux.relief" "$tmp/keep.relief" || { echo "FAIL existing output was damaged"; fails=$((fails + 1)); }
# corrupt files get a reason, not a crash
head -c 1000 "$tmp/lux.relief" > "$tmp/short.relief"
check info-truncated 1 "$relief" info "$tmp/short.relief"
expect_text info-truncated-named "truncated"
printf 'hello' > "$tmp/junk.relief"
check info-junk 1 "$relief" info "$tmp/junk.relief"
expect_text info-junk-named "too short"
check info-missing 1 "$relief" info "$tmp/none.relief"
expect_text info-missing-named "No such file"
# bench codec prints one JSON record per (file, method, tolerance)
check bench-codec 0 "$relief" bench codec "$data/luxembourg_elev.tif" --runs 1 --tolerances 1 --json
n=$(grep -c '"method":' <<<"$LAST_OUT")
[ "$n" -eq 3 ] || { echo "FAIL bench codec records: $n"; fails=$((fails + 1)); }
expect_text bench-codec-fields '"file":"luxembourg_elev.tif","method":"relief","tolerance_m":1,"bytes":'
expect_text bench-codec-cpu '"valid_samples":4608,"cpu":"'
check bench-unknown-mode 2 "$relief" bench frobnicate
# the daemon builds its GPU cache from the configured budget
printf '[gpu]\nbudget_mib = 16\n' > "$tmp/reliefd.conf"
vkcheck reliefd-terrain 0 "$reliefd" --config "$tmp/reliefd.conf" --check --terrain "$tmp/ps.relief"
expect_text reliefd-terrain-budget "budget 16 MiB), 5 decoded on the GPU, 0 bad"
vkcheck reliefd-terrain-missing 1 "$reliefd" --check --terrain "$tmp/none.relief"
expect_text reliefd-terrain-missing-named "none.relief"
vkcheck bench-decode 0 "$relief" bench decode "$tmp/lux.relief" --runs 1 --json
expect_text bench-decode-fields '"file":"lux.relief","patches":'
expect_text bench-decode-ratio '"ratio_gpu_over_cpu":'
# two levels: both submitted by the first update (the child's batch follows its parent's
# in flight), resident at the second
expect_text bench-decode-descent '"descent_updates":2,"levels":2,'
expect_text bench-decode-device '"device":"'
expect_text bench-decode-cpu '","cpu":"'
expect_text bench-decode-same-outputs '"cpu_normals_ms":'
expect_text bench-decode-strips '"cpu_strips_ms":'
# the equal-output ratio is (reference + normals) / GPU path, from the printed fields
field() { sed -n "s/.*\"$1\":\([-0-9.e]*\).*/\1/p" <<<"$LAST_OUT"; }
if ! awk -v c="$(field cpu_ref_ms)" -v n="$(field cpu_normals_ms)" -v s="$(field cpu_strips_ms)" -v g="$(field gpu_wall_ms)" \
	-v r="$(field ratio_same_outputs)" 'BEGIN { w = (c + n + s) / g; d = r - w; exit !(n > 0 && s > 0 && (d < 0 ? -d : d) <= 0.01 * w + 0.002) }'; then
	echo "FAIL bench-decode-same-outputs-ratio: $LAST_OUT"; fails=$((fails + 1))
fi
# one run: the three passes' times add up to the profiled runs' busy time (each printed to
# 0.01 ms; the timed runs take no timestamps between the passes)
if ! awk -v b="$(field gpu_profiled_busy_ms)" -v d="$(field gpu_decode_pass_ms)" -v n="$(field gpu_normals_pass_ms)" \
	-v s="$(field gpu_strips_pass_ms)" 'BEGIN { e = d + n + s - b; exit !(d > 0 && n > 0 && s > 0 && (e < 0 ? -e : e) <= 0.02) }'; then
	echo "FAIL bench-decode-passes: $LAST_OUT"; fails=$((fails + 1))
fi
# the device alone (every patch's symbols ready first): its batches run inside the timed
# flushes, so their busy time is at most the wall time; the ratio is the reference over it;
# its profiled runs time each pass
alone_ok() { # name
	if ! awk -v a="$(field gpu_alone_wall_ms)" -v b="$(field gpu_alone_busy_ms)" -v c="$(field cpu_ref_ms)" \
		-v r="$(field ratio_cpu_over_gpu_alone)" -v pd="$(field gpu_alone_decode_pass_ms)" \
		-v pn="$(field gpu_alone_normals_pass_ms)" -v ps="$(field gpu_alone_strips_pass_ms)" \
		'BEGIN { d = r - c / a; exit !(a > 0 && b > 0 && b <= a + 0.01 && (d < 0 ? -d : d) <= 0.01 * c / a + 0.002 && pd > 0 && pn > 0 && ps > 0) }'; then
		echo "FAIL $1: $LAST_OUT"; fails=$((fails + 1))
	else
		passes=$((passes + 1))
	fi
}
# the bound: the device-alone runs' process CPU time fits in the cores' time over their wall
# time, the bound is the reference over that time and the entropy stage's spread over the
# cores, and the GPU path took no less wall time than that spread (within a fifth: the runs
# are apart, and on a machine shared with other tests the wall time only grows); on a CPU
# device the process's CPU time holds the device's work, which its driver's threads do:
# at least half its busy time (1.1-1.9 times it on an idle machine; another test beside it
# stretches the busy time, not the CPU time: beside a GPU test on two cores it once read
# 0.26 on Luxembourg, so ctest runs this script alone, RUN_SERIAL in tests/CMakeLists.txt;
# the calling thread's clock alone reads 0.01-0.09)
bound_ok() { # name
	local cpu=0
	grep -q '"device_type":"CPU"' <<<"$LAST_OUT" && cpu=1
	if ! awk -v a="$(field gpu_alone_wall_ms)" -v u="$(field gpu_alone_cpu_ms)" -v n="$(field cores)" \
		-v c="$(field cpu_ref_ms)" -v e="$(field entropy_ms)" -v g="$(field gpu_wall_ms)" \
		-v r="$(field ratio_bound_cores)" -v b="$(field gpu_alone_busy_ms)" -v cpu="$cpu" \
		'BEGIN { w = (e + u) / n; d = r - c / w; exit !(u > 0 && n >= 1 && u <= n * a + 1 && (d < 0 ? -d : d) <= 0.01 * c / w + 0.002 && g >= 0.8 * w && (!cpu || u >= 0.5 * b)) }'; then
		echo "FAIL $1: $LAST_OUT"; fails=$((fails + 1))
	else
		passes=$((passes + 1))
	fi
}
alone_ok bench-decode-alone
bound_ok bench-decode-bound
# more patches than one chunk of the device-alone run (Puget Sound's 85: 64 and 21)
vkcheck bench-decode-chunks 0 "$relief" bench decode "$tmp/ps.relief" --runs 1 --json
expect_text bench-decode-chunks-patches '"file":"ps.relief","patches":85,'
alone_ok bench-decode-chunks-alone
bound_ok bench-decode-chunks-bound
# A level whose index window is smaller than its grid of patches (the crop: 3 x 2 of 4 x 4
# at the finest level): the CPU side takes each patch's block in entry order (it once
# read past the decoded blocks, which the sanitiser build reported).
check pack-crop 0 "$relief" pack "$data/alps-crop-140x100.f32" "$tmp/crop.relief" -q -t 1 --patch 65 \
	--raw-size 140x100 --raw-type float32 --spacing 92.7
vkcheck bench-decode-window 0 "$relief" bench decode "$tmp/crop.relief" --runs 1 --json
expect_text bench-decode-window-patches '"file":"crop.relief","patches":9,'
# relief snap: a real frame, its depth file, and refused cameras
vkcheck snap 0 "$relief" snap "$tmp/ps.relief" --camera 100000,50000,5500 --look 128480,79200,3000 --size 96x54 -o "$tmp/snap.png" --depth "$tmp/snap.f32" --wire
expect_text snap-summary "patches in"
[ "$(stat -c %s "$tmp/snap.f32")" -eq $((96 * 54 * 4)) ] || { echo "FAIL depth size"; fails=$((fails + 1)); }
# the top row looks at the sky: +infinity (0x7f800000, little-endian)
[ "$(head -c 4 "$tmp/snap.f32" | od -An -tx1 | tr -d ' ')" = "0000807f" ] || { echo "FAIL sky depth is not +inf"; fails=$((fails + 1)); }
# --exact: the frame measured triangle by triangle, under the validation layer, which the
# capture's pipelines keep quiet too (exit 1 on any message)
vkcheck snap-exact 0 "$relief" snap "$tmp/ps.relief" --camera 100000,50000,5500 --look 128480,79200,3000 --size 96x54 -o "$tmp/exact.png" --exact --validation
expect_text snap-exact-line "relief snap: exact: "
expect_text snap-exact-regular "regular triangles "
expect_text snap-exact-kinds ", other 0"
expect_text snap-exact-watertight "relief snap: exact: watertight: "
# --loose: the transition strips unbounded (relief_view.loose_transitions): fewer triangles.
vkcheck snap-loose 0 "$relief" snap "$tmp/ps.relief" --camera 100000,50000,5500 --look 128480,79200,3000 --size 96x54 -o "$tmp/loose.png" --loose
loose_tri=$(grep -o '[0-9]* triangles' <<<"$LAST_OUT" | head -1 | cut -d' ' -f1)
vkcheck snap-bounded 0 "$relief" snap "$tmp/ps.relief" --camera 100000,50000,5500 --look 128480,79200,3000 --size 96x54 -o "$tmp/bounded.png"
bounded_tri=$(grep -o '[0-9]* triangles' <<<"$LAST_OUT" | head -1 | cut -d' ' -f1)
[ -n "$loose_tri" ] && [ -n "$bounded_tri" ] && [ "$loose_tri" -lt "$bounded_tri" ] ||
	{ echo "FAIL snap --loose: $loose_tri triangles, bounded $bounded_tri"; fails=$((fails + 1)); }
vkcheck snap-nan 2 "$relief" snap "$tmp/ps.relief" --camera nan,0,100 --look 1,1,0 -o "$tmp/x.png"
expect_text snap-nan-named "--camera"
vkcheck snap-zero-size 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,100 --look 1,1,0 --size 0x10 -o "$tmp/x.png"
expect_text snap-zero-size-named "--size"
vkcheck snap-same-point 2 "$relief" snap "$tmp/ps.relief" --camera 5,5,100 --look 5,5,100 -o "$tmp/x.png"
expect_text snap-same-point-named "look point"
vkcheck snap-bad-roll 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,100 --look 1,1,0 --roll inf -o "$tmp/x.png"
expect_text snap-bad-roll-named "--roll"
# straight down (north up) and banked views render
vkcheck snap-nadir 0 "$relief" snap "$tmp/ps.relief" --camera 128480,79200,9000 --look 128480,79200,0 --size 48x32 -o "$tmp/nadir.png"
vkcheck snap-roll 0 "$relief" snap "$tmp/ps.relief" --camera 100000,50000,5500 --look 128480,79200,3000 --roll -30 --size 48x32 -o "$tmp/roll.png"
# --morph: the same level of detail (patches, triangles), only vertex heights blend
vkcheck snap-morph 0 "$relief" snap "$tmp/ps.relief" --camera 100000,50000,5500 --look 128480,79200,3000 --size 96x54 \
	-o "$tmp/morph.png" --morph
expect_text snap-morph-summary "patches in"
# relief fly: a short default flight from a cold cache, a track with two channels, bad tracks.
# Frames are not paced: the first ones draw whatever the decode worker has made resident,
# which may be nothing (CI once saw 7 frames under ASan + UBSan, on a loaded machine, all
# before the root patch). 61 frames give the worker nearly nine times as many.
vkcheck fly 0 "$relief" fly "$tmp/ps.relief" --seconds 1 --size 64x36 --json
expect_text fly-fields '"frames":61,"channels":1,"width":64,"height":36,"tau_px":1,"fps":60,'
expect_text fly-incomplete '"frames_incomplete":'
expect_text fly-latency '"first_complete_ms":'
levels=$(sed -n 's/.*"patches_by_level_last_frame":\[\([0-9,]*\)\].*/\1/p' <<<"$LAST_OUT")
if awk -F, -v l="$levels" 'BEGIN { n = split(l, v, ","); s = 0; for (i = 1; i <= n; i++) s += v[i]; exit !(n == 4 && s > 0) }'; then
	passes=$((passes + 1))
else
	echo "FAIL fly patches per level: '$levels'"; fails=$((fails + 1))
fi
# One channel: the round's span on the device is the channel's own time, frame for frame.
span=$(sed -n 's/.*"gpu_ms_median":\([0-9.]*\).*/\1/p' <<<"$LAST_OUT")
busy=$(sed -n 's/.*"gpu_busy_ms_median":\([0-9.]*\).*/\1/p' <<<"$LAST_OUT")
if [ -n "$span" ] && [ "$span" = "$busy" ] && awk -v s="$span" 'BEGIN { exit !(s > 0) }'; then
	passes=$((passes + 1))
else
	echo "FAIL fly GPU time of one channel: span '$span', channel '$busy'"; fails=$((fails + 1))
fi
printf '# t x y z heading pitch roll\n0 60000 40000 3000 45 -10 0\n1 61000 41000 3000 90 -90 30\n' >"$tmp/good.track"
vkcheck fly-track 0 "$relief" fly "$tmp/ps.relief" --track "$tmp/good.track" --fps 2 --channels 2 --size 48x32 --out "$tmp/fly"
expect_text fly-summary "3 frames of 2 channel(s)"
expect_text fly-summary-span "(first channel's start to last one's end; the channels' own times add up to "
expect_text fly-summary-levels "last frame         patches drawn per level 0..3:"
[ "$(ls "$tmp/fly" | wc -l)" -eq 6 ] || { echo "FAIL fly frames written: $(ls "$tmp/fly")"; fails=$((fails + 1)); }
# Each channel is drawn into a target of its own (all in flight at once): the side-by-side
# channels' pictures are the same only while the cold cache has nothing to draw (sky alone,
# a PNG of under 200 bytes at this size).
same_channels_sky_only() {
	for c0 in "$1"/frame-*-c0.png; do
		c1="${c0%-c0.png}-c1.png"
		if cmp -s "$c0" "$c1" && [ "$(stat -c %s "$c0")" -ge 200 ]; then
			echo "FAIL fly channels: $(basename "$c0") and its other channel show the same terrain"
			fails=$((fails + 1))
		fi
	done
}
same_channels_sky_only "$tmp/fly"
# The tools' own Vulkan paths under the validation layer (they exit 1 on any message): two
# morphed channels from a 2 MiB cache with two workers, and a wireframe snap with its depth
# file under GPU-assisted validation too. Whether the flight evicts depends on how fast the
# workers are (frames never wait; the sanitizer build's often do not fill the cache in 9
# frames), so it is not asserted here: test_patch_cache checks eviction under validation.
# 17 frames so that even a slow build has drawn terrain by the last (compared below).
vkcheck fly-validated 0 "$relief" fly "$tmp/ps.relief" --track "$tmp/good.track" --fps 16 --channels 2 --size 48x32 \
	--morph --budget 2 --workers 2 --validation --out "$tmp/flyv"
expect_text fly-validated-summary "17 frames of 2 channel(s)"
expect_text fly-validated-triangles "; triangles median "
same_channels_sky_only "$tmp/flyv"
cmp -s "$tmp/flyv/frame-00016-c0.png" "$tmp/flyv/frame-00016-c1.png" &&
	{ echo "FAIL fly channels: the last validated frame has the same picture in both channels"; fails=$((fails + 1)); }
RELIEF_GPU_AV=1 vkcheck snap-validated 0 "$relief" snap "$tmp/ps.relief" --camera 100000,50000,5500 \
	--look 128480,79200,3000 --size 96x54 -o "$tmp/v.png" --depth "$tmp/v.f32" --wire --morph --validation
# GPU-assisted validation leaves the device without pipeline statistics (vk.h): the count is
# said to be missing, not printed as 0.
expect_text snap-validated-uncounted "draws, triangles not counted (no pipeline statistics), GPU "
printf '0 60000 40000 3000 45 -10 0\n0 61000 41000 3000 90 -10 0\n' >"$tmp/bad.track"
check fly-bad-track 2 "$relief" fly "$tmp/ps.relief" --track "$tmp/bad.track"
expect_text fly-bad-track-named "bad.track: line 2: time 0 does not increase"
check fly-missing-track 2 "$relief" fly "$tmp/ps.relief" --track "$tmp/none.track"
expect_text fly-missing-track-named "none.track: cannot open"
check fly-directory-track 2 "$relief" fly "$tmp/ps.relief" --track "$tmp"
expect_text fly-directory-track-named "cannot read: Is a directory"
check fly-bad-fps 2 "$relief" fly "$tmp/ps.relief" --fps 0
expect_text fly-bad-fps-named "--fps"
check fly-bad-budget 2 "$relief" fly "$tmp/ps.relief" --budget 0
expect_text fly-bad-budget-named "--budget"
check fly-bad-channels 2 "$relief" fly "$tmp/ps.relief" --channels 9
expect_text fly-bad-channels-named "--channels"
vkcheck snap-bad-tau 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,100 --look 1,1,0 --tau -1 -o "$tmp/x.png"
expect_text snap-bad-tau-named "tau"
# beyond the GPU's float tau would become infinite there
vkcheck snap-huge-tau 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,100 --look 1,1,0 --tau 3.5e38 -o "$tmp/x.png"
expect_text snap-huge-tau-named "at most 3.4e38"
vkcheck snap-far-camera 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,1e300 --look 1,1,0 -o "$tmp/x.png"
expect_text snap-far-camera-named "within 1e12 m"
vkcheck snap-missing-look 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,100 -o "$tmp/x.png"
check snap-onto-input 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,100 --look 1,1,0 -o "$tmp/ps.relief"
check snap-depth-onto-png 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,100 --look 1,1,0 -o "$tmp/a.png" --depth "$tmp/a.png"
vkcheck snap-tiny-fov 2 "$relief" snap "$tmp/ps.relief" --camera 0,0,100 --look 1,1,0 --fov 0.005 -o "$tmp/x.png"
expect_text snap-tiny-fov-named "between 0.00573 and 179.99427 degrees"
# A list with an empty field is refused, not read as a shorter list (1,,2,3 once gave 1,2,3).
check snap-empty-field 2 "$relief" snap "$tmp/ps.relief" --camera 1,,2,3 --look 1,1,0 -o "$tmp/x.png"
expect_text snap-empty-field-named "--camera: '1,,2,3': value 2 is empty"
check bench-lod-empty-field 2 "$relief" bench lod "$tmp/ps.relief" --taus 1,2, --frames 1
expect_text bench-lod-empty-field-named "--taus: '1,2,': value 3 is empty"
check bench-lod-too-many 2 "$relief" bench lod "$tmp/ps.relief" --targets 1,2,3,4,5,6,7,8,9 --frames 1
expect_text bench-lod-too-many-named "--targets: '1,2,3,4,5,6,7,8,9' has more than 8 values"
check info-raster 1 "$relief" info "$data/ps_height_1k.png"
expect_text info-raster-named "not a .relief file (bad magic; \`relief pack\` makes one"
check pack-relief-input 1 "$relief" pack "$tmp/ps.relief" "$tmp/again.relief" -t 1
expect_text pack-relief-input-named "it is a .relief file"
check bench-codec-out-of-range 2 "$relief" bench codec "$data/luxembourg_elev.tif" --tolerances 1,0
expect_text bench-codec-out-of-range-named "--tolerances: 0 is outside [0.0001, 10000]"
check hello-signed-size 2 "$relief" hello --size +48x32
expect_text hello-signed-size-named "--size: '+48x32' is not WIDTHxHEIGHT"
vkcheck bench-lod 0 "$relief" bench lod "$tmp/ps.relief" --frames 2 --runs 2 --size 64x36 --taus 1 --targets 4 --json --validation
n=$(grep -c '"method":' <<<"$LAST_OUT")
[ "$n" -eq 4 ] || { echo "FAIL bench lod records: $n"; fails=$((fails + 1)); }
expect_text bench-lod-fields '"method":"relief","tau_px":1,"gpu_ms_median":'
expect_text bench-lod-error-fields '"max_err_px":'
expect_text bench-lod-popping '"popping_px":'
expect_text bench-lod-camera-popping '"camera_popping_px":'
# Popping events, counted out of the 2 pairs; the full grid's level of detail never
# changes, and in this short flight none of its pixels moves by more than the threshold.
expect_text bench-lod-popping-events '"popping_pairs":2,"popping_events":'
m=$(grep '"method":"full-grid"' <<<"$LAST_OUT" | grep -c '"popping_events":0,"popping_event_pixels":0,')
[ "$m" -eq 1 ] || { echo "FAIL bench lod popping events: the full grid pops"; fails=$((fails + 1)); }
# Each event's quads compared (lavapipe has the capture): the full grid has none to count.
m=$(grep '"method":"full-grid"' <<<"$LAST_OUT" | grep -c '"popping_event_interiors":0,"popping_event_edges":0,"popping_event_coarse":0')
[ "$m" -eq 1 ] || { echo "FAIL bench lod popping event quads of the full grid"; fails=$((fails + 1)); }
# The full grid's own changed pixels are left out of the others' popping: never more than it has.
fg=$(grep '"method":"full-grid"' <<<"$LAST_OUT" | sed -n 's/.*"popping_event_pixels":\([0-9]*\).*/\1/p')
m=$(sed -n 's/.*"popping_excluded_pixels":\([0-9]*\).*/\1/p' <<<"$LAST_OUT" | awk -v fg="${fg:--1}" '$1 <= fg + 0' | wc -l)
[ "$m" -eq 4 ] || { echo "FAIL bench lod popping_excluded_pixels over the full grid's $fg: $m of 4 within"; fails=$((fails + 1)); }
expect_text bench-lod-runs '"frames":4,"runs":2,'
# Curtain pixels: counted for every method, never for the reference (it is not measured
# against itself).
m=$(grep -c '"curtain_pixels":[0-9]*,' <<<"$LAST_OUT")
[ "$m" -eq 4 ] || { echo "FAIL bench lod curtain_pixels: $m of 4 records"; fails=$((fails + 1)); }
m=$(grep '"method":"full-grid"' <<<"$LAST_OUT" | grep -c '"curtain_pixels":0,')
[ "$m" -eq 1 ] || { echo "FAIL bench lod curtain_pixels of the full grid"; fails=$((fails + 1)); }
# The awk checks of JSON records below read their numbers through num().
awk_num='function num(text, key) { # the first number after "key": in text
	if (!match(text, "\"" key "\":[0-9.]+")) return -1
	return substr(text, RSTART + length(key) + 3, RLENGTH - length(key) - 3) + 0
}
'
# At equal measured error: relief's record names, for each baseline with a configuration at
# least as accurate, the fastest such one, and its speedup is that one's time over relief's.
# The full grid is there: on these frames its largest error (0.01 px) is below relief's.
equal=$(grep '"method":"relief"' <<<"$LAST_OUT" | awk "$awk_num"'
{
	ms = num($0, "gpu_ms_median"); err = num($0, "max_err_px")
	if (!match($0, /"at_equal_error":\[[^]]*\]/)) { print "none"; exit }
	n = split(substr($0, RSTART, RLENGTH), e, /\},\{/); ok = 0
	for (i = 1; i <= n; i++) {
		be = num(e[i], "max_err_px"); bms = num(e[i], "gpu_ms_median"); sp = num(e[i], "speedup")
		d = sp - bms / ms; if (d < 0) d = -d
		if (be <= err && d <= 0.002 * sp + 0.001) ok++
	}
	print ok " of " n (index($0, "\"at_equal_error\":[{\"baseline\":\"full-grid\"") ? " full-grid" : "")
}')
case "$equal" in
"1 of 1 full-grid" | "2 of 2 full-grid" | "3 of 3 full-grid") passes=$((passes + 1)) ;;
*) echo "FAIL bench lod at_equal_error: $equal entries consistent"; fails=$((fails + 1)) ;;
esac
expect_text bench-lod-face-cull '"face_culled_frames":4' # the flight is above the terrain
expect_text bench-lod-cpu '","cpu":"'
# Triangle by triangle (lavapipe has the capture): every method but the full grid, which
# draws the finest surface itself, has a measured error, and the full grid's is 0.
expect_text bench-lod-mesh '"max_err_mesh_px":'
expect_text bench-lod-mesh-full-grid '"max_err_mesh_px":0.0000,'
# Transition triangles by kind, and, with relief's and chunked LOD's power-of-two factors,
# none of another kind: every one lies in a column of an edge's strip (docs/lod.md,
# "Transition triangles: what bounds them"). The distance baseline's factors are not
# powers of two: its transitions are of no kind.
expect_text bench-lod-mesh-kinds '"max_err_mesh_coarse_edge_px":'
m=$(grep -E '"method":"(relief|chunked)"' <<<"$LAST_OUT" | grep -c '"other_triangles":0,')
[ "$m" -eq 2 ] || { echo "FAIL bench lod other triangles: $m of relief and chunked have none"; fails=$((fails + 1)); }
# Every method's meshes are watertight over the flight (relief_mesh_seams()).
m=$(grep -c '"max_err_mesh_px":' <<<"$LAST_OUT")
s=$(grep -c '"mesh_seams":0[,}]' <<<"$LAST_OUT")
if [ "$m" -ge 4 ] && [ "$s" -eq "$m" ]; then passes=$((passes + 1)); else
	echo "FAIL bench lod mesh seams: $s of $m measured methods watertight"; fails=$((fails + 1))
fi
# Where the captured triangles fall (tools/mesh_cover.h): the five kinds add up to the
# triangles the device counted (pipeline statistics) in the same frames.
m=$(awk "$awk_num"'
/"method":/ {
	t = num($0, "triangles"); s = 0
	for (i = split("tri_outside tri_eye tri_back tri_no_pixel tri_pixels", k, " "); i > 0; i--) {
		v = num($0, k[i]); if (v < 0) next
		s += v
	}
	d = s - t; if (d < 0) d = -d
	if (t > 0 && d <= 0.001 * t + 0.1 && num($0, "pixels_per_tri") >= 1) ok++
}
END { print ok + 0 }' <<<"$LAST_OUT")
[ "$m" -eq 4 ] || { echo "FAIL bench lod triangle kinds: $m of 4 records add up to their triangles"; fails=$((fails + 1)); }
# One run for three options, each of which adds methods or measures: --unculled (relief and
# chunked also drawn without block culling, in turn with the rest), --morphed (relief also
# drawn with geomorphing) and --recheck-all (every pixel measured again at three times the
# resolution with three times tau).
vkcheck bench-lod-options 0 "$relief" bench lod "$tmp/ps.relief" --frames 2 --runs 1 --size 64x36 --taus 1 --targets 4 \
	--unculled --morphed --recheck-all --json
n=$(grep -c '"method":' <<<"$LAST_OUT")
[ "$n" -eq 7 ] || { echo "FAIL bench lod --unculled --morphed --recheck-all records: $n"; fails=$((fails + 1)); }
field() { grep "\"method\":\"$1\"" <<<"$LAST_OUT" | sed -n "s/.*\"$2\":\([0-9.e+-]*\).*/\1/p"; }
# --unculled: culling draws no more triangles and changes no error (the picture is the same).
culled=$(field relief triangles) unculled=$(field relief-unculled triangles)
if [ -n "$culled" ] && [ -n "$unculled" ] && awk -v a="$culled" -v b="$unculled" 'BEGIN { exit !(a <= b) }' &&
	[ "$(field relief max_err_px)" = "$(field relief-unculled max_err_px)" ] &&
	[ "$(field chunked rms_err_px)" = "$(field chunked-unculled rms_err_px)" ]; then
	passes=$((passes + 1))
else
	echo "FAIL bench lod --unculled: triangles $culled culled, $unculled not; errors differ?"
	fails=$((fails + 1))
fi
# --morphed: finer levels (a morphing view takes level d + 1 only where eps_{d+1} + eps_d is
# within the allowed error: docs/lod.md, "Morphing"), so at least as many triangles, every
# error within tau, at pixels and on every triangle
if awk -v a="$(field relief triangles)" -v b="$(field relief-morphed triangles)" \
	-v e="$(field relief-morphed max_err_px)" -v m="$(field relief-morphed max_err_mesh_px)" \
	'BEGIN { exit !(a != "" && b + 0 >= a + 0 && e != "" && e <= 1.0 && m != "" && m <= 1.0) }'; then
	passes=$((passes + 1))
else
	echo "FAIL bench lod --morphed: triangles $(field relief triangles) and $(field relief-morphed triangles)"
	fails=$((fails + 1))
fi
# --recheck-all: the same level of detail (no pixel unresolved: another triangle count would
# leave them all so) and the same rays: the RMS change of a pixel's error is 0.0002-0.0013 px
# here (single far slivers up to 0.08 px), 0.01-0.09 px with pixel 3x, 3y for 3x + 1, 3y + 1.
ok=1
for m in relief chunked relief-morphed; do
	px=$(field "$m" pixels) over=$(field "$m" over_tau_pixels) un=$(field "$m" unresolved_pixels)
	diff=$(field "$m" recheck_rms_diff_px)
	if [ -z "$px" ] || [ "$px" -eq 0 ] || [ "$over" != "$px" ] || [ "$un" != 0 ] ||
		! awk -v d="$diff" 'BEGIN { exit !(d != "" && d <= 0.003) }'; then
		echo "FAIL bench lod --recheck-all $m: $px pixels, $over rechecked, $un unresolved, RMS change $diff px"
		ok=0
	fi
done
[ -z "$(field distance over_tau_pixels)" ] || { echo "FAIL bench lod: distance has no tau to recheck"; ok=0; }
if [ "$ok" -eq 1 ]; then passes=$((passes + 1)); else fails=$((fails + 1)); fi
# --passes: one more run with a timestamp after each LOD pass. With one key pose a run has
# two frames, whose median is their mean, so each record's pass medians add up to the
# median of their sum (each printed to 0.0001 ms), and every pass took some time.
vkcheck bench-lod-passes 0 "$relief" bench lod "$tmp/crop.relief" --frames 1 --runs 1 --size 64x36 --taus 1 --targets 4 \
	--passes --json
m=$(sed -n 's/.*"lod_profiled_ms_median":\([0-9.]*\),"lod_pass_ms":{"setup":\([0-9.]*\),"select":\([0-9.]*\),"borders":\([0-9.]*\),"factors":\([0-9.]*\),"lists":\([0-9.]*\)}.*/\1 \2 \3 \4 \5 \6/p' <<<"$LAST_OUT" |
	awk '{ s = 0; ok = 1; for (i = 2; i <= 6; i++) { s += $i; ok = ok && $i > 0 } d = s - $1; if (ok && (d < 0 ? -d : d) <= 0.0007) n++ } END { print n + 0 }')
[ "$m" -eq 4 ] || { echo "FAIL bench lod --passes: $m of 4 records whose passes add up: $LAST_OUT"; fails=$((fails + 1)); }
vkcheck bench-lod-passes-text 0 "$relief" bench lod "$tmp/crop.relief" --frames 1 --runs 1 --size 64x36 --taus 1 --targets 4 \
	--passes
expect_text bench-lod-passes-table "setup   select  borders  factors    lists  profiled"
expect_text bench-lod-equal-error-table "At equal or lower error: each baseline's fastest configuration"
# --every-frame: popping over every frame of the flight's line (the crop: 380 frames), each
# method's LOD chosen for all of them in turn; the pairs measured are the LOD-change pairs
# of any method and 4 spread evenly. The full grid's LOD never changes (its popping is 0).
vkcheck bench-lod-every-frame 0 "$relief" bench lod "$tmp/crop.relief" --every-frame 4 --runs 1 --size 64x36 --taus 1 \
	--targets 4 --json
n=$(grep -c '"flight_pairs":379,"lod_change_pairs":[0-9]*,"sampled_pairs":[1-4],"popping_se_px":' <<<"$LAST_OUT")
[ "$n" -eq 4 ] || { echo "FAIL bench lod --every-frame: $n of 4 records with the line's pairs: $LAST_OUT"; fails=$((fails + 1)); }
m=$(grep '"method":"full-grid"' <<<"$LAST_OUT" | grep -c '"popping_px":0.00000,')
[ "$m" -eq 1 ] || { echo "FAIL bench lod --every-frame: the full grid pops"; fails=$((fails + 1)); }
check bench-lod-every-frame-and-frames 2 "$relief" bench lod "$tmp/crop.relief" --every-frame 4 --frames 2
expect_text bench-lod-every-frame-and-frames-named "--frames and --every-frame exclude each other"
vkcheck bench-lod-zero-runs 2 "$relief" bench lod "$tmp/ps.relief" --runs 0
expect_text bench-lod-zero-runs-named "--runs"
echo "cli: $passes passed, $fails failed"
[ "$fails" -eq 0 ]
