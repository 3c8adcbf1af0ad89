#!/bin/sh
# Build an example flight-software library against rcsim's C ABI header.
#   sh examples/c_fsw/build.sh [SOURCE.c] [OUT.so]     (defaults: switching_line.c, beside it)
# Needs a C compiler (cc) and the Python that has rcsim installed (PYTHON, default python3).
set -eu
here=$(dirname "$0")
src=${1:-$here/switching_line.c}
out=${2:-${src%.c}.so}
include=$("${PYTHON:-python3}" -c 'from rcsim.lookup.c_library import header_path; print(header_path().parent)')
"${CC:-cc}" -O2 -std=c99 -Wall -Wextra -ffp-contract=off -shared -fPIC -I "$include" -o "$out" "$src" -lm
echo "$out"
