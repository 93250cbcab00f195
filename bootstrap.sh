#!/usr/bin/env bash
# One-time (and idempotent) set-up: a Python >= 3.11 virtual environment in .venv
# with the pinned packages of requirements.lock, this package installed editable,
# and a system libLLVM that drjit's CPU backend can use (>= 16; Debian's libllvm19).
# Re-running it is cheap: it only reinstalls when requirements.lock or pyproject.toml change.
# Opt-in: `bash bootstrap.sh --slurm` (or CLOTHSCOPE_SLURM=1) also installs the SLURM executor
# pinned in requirements-slurm.lock (for workflow/profiles/slurm).
set -euo pipefail
cd "$(dirname "$0")"

die() { echo "bootstrap: $*" >&2; exit 1; }
SLURM=${CLOTHSCOPE_SLURM:-0}
for arg in "$@"; do
  case $arg in
    --slurm) SLURM=1 ;;
    *) die "unknown option '$arg' (the only option is --slurm)" ;;
  esac
done
as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then sudo "$@"; else return 1; fi; }
apt_install() {
  command -v apt-get >/dev/null || return 1
  as_root env DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null &&
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}

PYTHON=${PYTHON:-python3}
command -v "$PYTHON" >/dev/null || die "python3 not found: install Python 3.11 (apt-get install python3)"
"$PYTHON" -c 'import sys; sys.exit(sys.version_info < (3, 11))' || die "Python >= 3.11 needed, found $("$PYTHON" --version 2>&1)"

# drjit's LLVM backend: libLLVM 15 crashes, 19 works.
have_llvm() { { ls /usr/lib/*/libLLVM*.so* /usr/lib64/libLLVM*.so* 2>/dev/null || true; } | grep -Eq 'libLLVM[-.]?(so\.)?(1[6-9]|[2-9][0-9])'; }
if ! have_llvm; then
  echo "bootstrap: installing libllvm19 (drjit needs libLLVM >= 16)"
  apt_install libllvm19 || die "no libLLVM >= 16 found and cannot install it: run 'sudo apt-get install libllvm19' (or set DRJIT_LIBLLVM_PATH)"
fi

if [ ! -x .venv/bin/python ]; then
  if ! "$PYTHON" -m venv .venv 2>/dev/null; then
    rm -rf .venv
    pyver=$("$PYTHON" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')
    apt_install "python${pyver}-venv" || apt_install python3-venv || die "cannot create a virtual environment: run 'sudo apt-get install python3-venv'"
    "$PYTHON" -m venv .venv
  fi
fi

stamp=.venv/.clothscope-installed
want=$(cat requirements.lock pyproject.toml | sha256sum | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "bootstrap: installing pinned Python packages into .venv (first run: a few minutes)"
  .venv/bin/python -m pip install -q --upgrade pip
  .venv/bin/python -m pip install -q -r requirements.lock
  .venv/bin/python -m pip install -q --no-deps -e .
  echo "$want" > "$stamp"
fi
if [ "$SLURM" = 1 ]; then
  slurm_stamp=.venv/.clothscope-slurm-installed
  slurm_want=$(cat requirements-slurm.lock requirements.lock | sha256sum | cut -d' ' -f1)
  if [ "$(cat "$slurm_stamp" 2>/dev/null)" != "$slurm_want" ]; then
    echo "bootstrap: installing the pinned SLURM executor plugin into .venv"
    .venv/bin/python -m pip install -q -r requirements-slurm.lock -c requirements.lock
    echo "$slurm_want" > "$slurm_stamp"
  fi
fi
.venv/bin/python -c 'from clothscope.core.runtime import mitsuba_for; mi = mitsuba_for("auto"); print("bootstrap: ready, Mitsuba", mi.__version__, "variant", mi.variant())'
