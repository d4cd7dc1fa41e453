#!/usr/bin/env bash
# New machine -> set up, build, run every test; then the fast suite again under
# AddressSanitizer + UBSan; then each parser's fuzzer briefly.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
start=$(date +%s)

echo "== build (release) =="
scripts/build.sh build
echo "== tests (release) =="
(cd build && ctest --output-on-failure -j2 --timeout 1500)

echo "== build (ASan+UBSan) =="
scripts/build.sh build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMGS_SANITIZE=ON
echo "== fast tests (ASan+UBSan) =="
(cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 LSAN_OPTIONS=suppressions="$PWD/../scripts/lsan.supp" \
   UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
   ctest --output-on-failure -j2 -L fast --timeout 1500)

echo "== fuzzers (libFuzzer) =="
scripts/fuzz.sh "${MGS_FUZZ_SECONDS:-20}"
echo "test.sh: all suites passed in $(( $(date +%s) - start )) s"
