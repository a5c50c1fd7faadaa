#!/bin/sh
# The pip route of bindings/python/README.md, offline: install the built
# library into a temporary prefix, create a venv that sees the system's
# site-packages (numpy, setuptools, pip), pip-install a copy of
# bindings/python into it with --no-build-isolation, then import hetinv from
# outside the source tree with nothing pointing at the build: the package
# must find the installed library through pkg-config (PKG_CONFIG_PATH) and
# render with it. Exits 77 (skipped) when venv, pip or setuptools is missing.
#   usage: pip_install.sh <source dir> <build dir> <scratch dir> <python>
set -eu
src=$1
build=$2
work=$3
python=$4
rm -rf "$work"
mkdir -p "$work/elsewhere"
prefix=$work/prefix

skip() {
  echo "SKIPPED: $*"
  exit 77
}

# The top-level install rules only (library, headers, hetinv.pc, CMake
# package): the examples' rules would need every example built.
cmake -DCMAKE_INSTALL_PREFIX="$prefix" -DCMAKE_INSTALL_LOCAL_ONLY=ON -P "$build/cmake_install.cmake" \
  >"$work/install.log"
libdir=$(cd "$prefix" && ls -d lib* | head -n 1)
test -f "$prefix/$libdir/pkgconfig/hetinv.pc" || { echo "no hetinv.pc in $prefix/$libdir"; exit 1; }

"$python" -c "import venv" 2>/dev/null || skip "$python has no venv module (Debian: apt-get install python3-venv)"
# Without ensurepip the venv uses the system's pip (instant); if there is
# none, let venv install its own (Debian: python3-venv brings the wheels).
"$python" -m venv --without-pip --system-site-packages "$work/venv"
venv_python=$work/venv/bin/python
if ! "$venv_python" -m pip --version >/dev/null 2>&1; then
  rm -rf "$work/venv"
  "$python" -m venv --system-site-packages "$work/venv" >"$work/venv.log" 2>&1 ||
    skip "cannot create a venv with pip (Debian: apt-get install python3-venv python3-pip); see $work/venv.log"
fi
"$venv_python" -c "import setuptools" 2>/dev/null ||
  skip "no setuptools for $python (Debian: apt-get install python3-setuptools)"
# setuptools before 70.1 builds wheels with the separate 'wheel' package.
"$venv_python" -c "import importlib.util as u, sys
sys.exit(not (u.find_spec('wheel') or u.find_spec('setuptools.command.bdist_wheel')))" 2>/dev/null ||
  skip "setuptools for $python cannot build wheels (Debian: apt-get install python3-wheel)"

# A copy, so pip's in-tree build leaves no build/ or *.egg-info in the sources.
cp -R "$src/bindings/python" "$work/binding"
rm -rf "$work/binding/build" "$work/binding"/*.egg-info
# Nothing from the build or the test environment may help the import.
unset HETINV_LIBRARY PYTHONPATH LD_LIBRARY_PATH
PKG_CONFIG_PATH=$prefix/$libdir/pkgconfig
export PKG_CONFIG_PATH PIP_NO_INDEX=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PYTHONDONTWRITEBYTECODE=1
"$venv_python" -m pip install --no-build-isolation --no-deps "$work/binding" >"$work/pip.log" 2>&1 ||
  { cat "$work/pip.log"; echo "pip install failed"; exit 1; }
echo "== pip install --no-build-isolation: $(tail -n 1 "$work/pip.log")"

cd "$work/elsewhere"
cat >check.py <<'PY'
import os
import sys

import hetinv

prefix, venv = os.path.realpath(sys.argv[1]), os.path.realpath(sys.argv[2])
package = os.path.realpath(hetinv.__file__)
library = os.path.realpath(hetinv.library_path)
print("package", package)
print("library", hetinv.library_path, "version", hetinv.version(), "numpy", hetinv.numpy_enabled())
assert package.startswith(venv + os.sep), "hetinv imported from %s, not the venv" % package
assert library.startswith(prefix + os.sep), "libhetinv loaded from %s, not %s" % (library, prefix)
assert hetinv.__version__ == hetinv.version(), (hetinv.__version__, hetinv.version())
with hetinv.Context(seed=1, threads=1) as ctx:
    slab = hetinv.Medium(ctx, (-5, -5, 0), (5, 5, 1), (2, 1, 1)).fill(0.1, 5.0, 0.8).commit()
    rows = hetinv.Measurements(ctx)
    rows.add(hetinv.Emitter.ideal(slab, (0, 0, 2), (0, 0, -1)),
             hetinv.Sensor.hemispherical(slab, "z_max"))
    r = hetinv.Estimator(ctx, photons=2000).render(slab, rows)
    assert 0.0 < r.values[0] < 1.0, r.values[0]
    grid = slab.grid("sigma_s")
    assert len(hetinv.flat(grid)) == 2
    if hetinv.numpy_enabled():
        assert grid.shape == (1, 1, 2), grid.shape
    print("Rd = %.4f +- %.4f" % (r.values[0], r.std_errors[0]))
PY
"$venv_python" check.py "$prefix" "$work/venv"

# Without pkg-config's help (and no other install), the import fails with
# the list of places it looked.
if PKG_CONFIG_PATH=$work/elsewhere "$venv_python" -c "import hetinv" 2>err.txt; then
  echo "(another libhetinv is installed on this system: the not-found message is not checked)"
else
  grep -q "pkg-config libdir: nothing found" err.txt || { cat err.txt; exit 1; }
  grep -q "HETINV_LIBRARY" err.txt || { cat err.txt; exit 1; }
fi
echo "pip install check passed"
