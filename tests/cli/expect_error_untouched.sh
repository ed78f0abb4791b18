#!/usr/bin/env bash
# expect_error_untouched.sh OUTDIR REGEX CMD...: as expect_error.sh, and OUTDIR must not exist
# afterwards (a refused restart touches nothing).
out=$1; shift
rm -rf "$out"
bash "$(dirname "$0")/expect_error.sh" "$@" || exit 1
if [ -e "$out" ]; then echo "the refused run created $out"; exit 1; fi
