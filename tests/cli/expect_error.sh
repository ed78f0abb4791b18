#!/usr/bin/env bash
# expect_error.sh REGEX CMD...: passes if CMD exits non-zero and its stderr matches REGEX.
regex=$1; shift
err=$("$@" 2>&1 >/dev/null); rc=$?
if [ $rc -eq 0 ]; then echo "expected a non-zero exit from: $*"; exit 1; fi
if ! grep -Eq -- "$regex" <<<"$err"; then echo "stderr does not match '$regex':"; echo "$err"; exit 1; fi
echo "ok (exit $rc): $err"
