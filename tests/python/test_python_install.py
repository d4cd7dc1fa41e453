"""scripts/python.sh installs the built package into a venv over Debian's python3 (offline:
pip without build isolation or an index), and that venv imports it without PYTHONPATH.
MGS_PY_NO_BUILD=1: the test installs the build it belongs to, it does not rebuild it."""
import os
import shutil
import subprocess

import pyt


def test_install_into_fresh_venv():
    d = pyt.tmpdir("install")
    venv = os.path.join(d, "venv")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env.update(MGS_PY_NO_BUILD="1", MGS_BUILD=pyt.BINARY_DIR, MGS_VENV=venv)
    r = subprocess.run([os.path.join(pyt.SOURCE_DIR, "scripts", "python.sh")], env=env, capture_output=True, text=True)
    assert r.returncode == 0, (r.stdout, r.stderr)
    code = ("import morsegs, numpy, sys; c = morsegs.CubicalComplex(vertices=numpy.arange(8.0).reshape(2, 2, 2)); "
            "assert c.persistence() == [(0, (0.0, float('inf')))], c.persistence(); "
            "assert morsegs.__file__.startswith(sys.prefix), morsegs.__file__; print(morsegs.__file__)")
    r = subprocess.run([os.path.join(venv, "bin", "python"), "-c", code], env=env, capture_output=True, text=True,
                       cwd=d)
    assert r.returncode == 0, (r.stdout, r.stderr)
    print("  ", r.stdout.strip())
    # Debian's packages stay visible (--system-site-packages)
    r = subprocess.run([os.path.join(venv, "bin", "python"), "-c", "import gudhi, pyopenvdb"], env=env, cwd=d)
    assert r.returncode == 0
    shutil.rmtree(d)


if __name__ == "__main__":
    pyt.run(globals())
