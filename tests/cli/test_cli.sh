#!/usr/bin/env bash
# Command-line contract of relief and reliefd: versions agree, usage errors exit 2 with a
# message naming the problem, --help exits 0.
set -u
relief=$1 reliefd=$2
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
echo "cli: $passes passed, $fails failed"
[ "$fails" -eq 0 ]
