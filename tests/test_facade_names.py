"""The facade's names stay what they are once the package's subpackages are imported.

Python binds a subpackage to its parent's attribute of the same name on its first import, so a facade
function named like a subpackage would silently become a module (``pc.campaign(...)`` raising
"'module' object is not callable" after any ``pc.run``). Checked in a fresh interpreter, since this
session has imported everything already.
"""

import subprocess
import sys

import postcapture


def test_facade_functions_survive_importing_every_subpackage():
    code = (
        "import pkgutil, importlib, postcapture as pc\n"
        "for m in pkgutil.walk_packages(pc.__path__, 'postcapture.'):\n"
        "    if m.name.endswith('__main__'): continue\n"
        "    importlib.import_module(m.name)\n"
        "bad = [n for n in pc.__all__ if n != '__version__' and not callable(getattr(pc, n))]\n"
        "assert not bad, bad\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


def test_no_facade_name_is_a_subpackage():
    import pkgutil

    subpackages = {m.name for m in pkgutil.iter_modules(postcapture.__path__)}
    assert not subpackages & set(postcapture.__all__)
