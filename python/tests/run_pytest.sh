#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Installs the build into a prefix of its own and runs the Python package's tests against that install:
#   run_pytest.sh BUILD_DIR SOURCE_DIR LFI_EXECUTABLE PYTHON_DIR PYTHON
set -eu
build=$1 source=$2 lfi=$3 pydir=$4 python=$5
prefix=$(mktemp -d "${TMPDIR:-/tmp}/lfi-python-XXXXXX")
trap 'rm -rf "$prefix"' EXIT
cmake --install "$build" --prefix "$prefix" >/dev/null
cd "$prefix"
LFI_SOURCE_DIR=$source LFI_EXECUTABLE=$lfi PYTHONPATH="$prefix/$pydir" \
  "$python" -m pytest -q -p no:cacheprovider --basetemp="$prefix/pytest" "$source/python/tests"
