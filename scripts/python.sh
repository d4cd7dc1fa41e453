#!/usr/bin/env bash
# Builds the Python module (`import morsegs`) and installs it into .venv/ at the repository
# root: a venv over Debian's /usr/bin/python3 with --system-site-packages (numpy, GUDHI,
# pyopenvdb stay Debian's), the built package installed by pip with no build isolation and
# no index (nothing is downloaded). Then:  .venv/bin/python -c "import morsegs"
# Environment: MGS_BUILD (build dir, default build), MGS_VENV (default .venv),
# MGS_PY_NO_BUILD=1 (install what MGS_BUILD holds, do not build).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${MGS_BUILD:-build}
venv=${MGS_VENV:-.venv}
py=/usr/bin/python3  # Debian's: the first python3 on PATH may be a pyenv one without numpy
if [ "${MGS_PY_NO_BUILD:-0}" != 1 ]; then
  scripts/setup.sh
  MGS_TARGET=morsegs_python scripts/build.sh "$build" "$@"
fi
pkg="$build/python"
if ! ls "$pkg"/morsegs/_morsegs*.so > /dev/null 2>&1; then
  echo "python.sh: $pkg/morsegs/_morsegs*.so is missing (was the build configured with -DMGS_PYTHON=OFF or -DMGS_SANITIZE=ON?)" >&2
  exit 1
fi
[ -x "$venv/bin/python" ] || "$py" -m venv --system-site-packages "$venv"
# pip builds in a copy: the build tree stays free of egg-info and build/ folders.
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
cp -r "$pkg/pyproject.toml" "$pkg/morsegs" "$stage/"
rm -rf "$stage/morsegs/__pycache__"
PIP_NO_INDEX=1 PIP_DISABLE_PIP_VERSION_CHECK=1 "$venv/bin/python" -m pip install -q --no-build-isolation --no-deps \
  --force-reinstall "$stage"
"$venv/bin/python" -c "import morsegs, sys; print('python.sh: morsegs', morsegs.__version__, 'in', sys.prefix)"
