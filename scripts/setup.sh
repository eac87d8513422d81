#!/usr/bin/env bash
# Create .venv, install mitnerf (+ extras given as $1, e.g. "test"), and make sure
# Dr.Jit loads an LLVM >= 16 (Debian 12's libLLVM-15 aborts Mitsuba with
# "Cannot select ... fmaximum"); installs libllvm19 with apt when it does not.
set -euo pipefail
cd "$(dirname "$0")/.."
extras="${1:-}"
py="${PYTHON:-python3.11}"
command -v "$py" >/dev/null || py=python3
if [ ! -x .venv/bin/python ]; then
    "$py" -m venv .venv
fi
spec="."
[ -n "$extras" ] && spec=".[$extras]"
.venv/bin/python -m pip install -q -e "$spec"

llvm_major() {
    .venv/bin/python -c \
        "import drjit; print(drjit.detail.llvm_version()[0])" 2>/dev/null || echo -1
}
major=$(llvm_major | tail -n 1)
if [ "${major:--1}" -lt 16 ]; then
    echo "setup: Dr.Jit loads LLVM ${major}; installing libllvm19 (LLVM >= 16 is required)"
    sudo_=""
    [ "$(id -u)" -ne 0 ] && sudo_="sudo"
    $sudo_ apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo_ apt-get install -y -qq libllvm19 >/dev/null
    major=$(llvm_major | tail -n 1)
    if [ "${major:--1}" -lt 16 ]; then
        echo "setup: Dr.Jit still loads LLVM ${major}; set DRJIT_LIBLLVM_PATH to libLLVM.so.19" >&2
        exit 1
    fi
fi
echo "setup: ok (.venv, LLVM ${major})"
