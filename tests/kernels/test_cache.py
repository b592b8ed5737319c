"""The compiled kernels' cache (proxyshade/kernels/_cache.py): one folder per version of
the whole kernels package, so a kernel that inlines another module's function never runs
machine code compiled against that module's old source."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import time
import sys
from pathlib import Path

import proxyshade

PKG = Path(proxyshade.__file__).resolve().parent

# a kernel module calling another module's jitted function, as correct.py calls random.rand
PROBE = '''"""A kernel inlining random.rand."""
from numba import njit

from proxyshade.kernels._config import JIT
from proxyshade.kernels.random import rand


@njit(**JIT)
def probe():
    return rand(1, 2, 3, 4)
'''

CHILD = r"""
import json
from proxyshade.kernels import _cache, probe, random
print(json.dumps({"probe": int(probe.probe()), "rand": int(random.rand.py_func(1, 2, 3, 4)),
                  "hits": sum(probe.probe.stats.cache_hits.values()), "folder": str(_cache.folder())}))
"""


def test_an_edit_to_a_kernel_module_recompiles_the_kernels_that_inline_it(tmp_path):
    """In a copy of the package with its own numba cache: a kernel calling ``random.rand``
    is compiled and cached; after ``rand`` is edited a fresh process computes with the new
    ``rand`` (numba alone would load the caller's stale machine code: its own file did not
    change); a comment-only edit keeps the compiled kernels; ``cache clean`` removes the
    old version's folder."""
    root = tmp_path / "src"
    shutil.copytree(PKG, root / "proxyshade", ignore=shutil.ignore_patterns("__pycache__"))
    kernels = root / "proxyshade" / "kernels"
    (kernels / "probe.py").write_text(PROBE)
    env = dict(os.environ, PYTHONPATH=str(root), NUMBA_CACHE_DIR=str(tmp_path / "numba"),
               XDG_CACHE_HOME=str(tmp_path / "xdg"), PROXYSHADE_CODE_CACHE=str(tmp_path / "code"))

    def child(code=CHILD, *args):
        r = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True,
                           timeout=120, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        return r.stdout

    first = json.loads(child())
    assert first["probe"] == first["rand"] and first["hits"] == 0
    assert Path(first["folder"]).parent == tmp_path / "numba" / "proxyshade-kernels"  # NUMBA_CACHE_DIR respected
    again = json.loads(child())
    assert again == dict(first, hits=1)  # loaded from the cache: the test below is not vacuous

    src = kernels / "random.py"
    text = src.read_text()
    assert "return np.int64(x >> np.uint64(11))" in text
    src.write_text(text.replace("return np.int64(x >> np.uint64(11))", "return np.int64(x >> np.uint64(12))"))
    edited = json.loads(child())
    assert edited["rand"] != first["rand"]
    assert edited["probe"] == edited["rand"]  # the caller runs the new rand
    assert edited["folder"] != first["folder"] and edited["hits"] == 0

    src.write_text(src.read_text() + "\n# a comment changes no compiled code\n")
    commented = json.loads(child())
    assert commented == dict(edited, hits=1)

    # a version written to in the last hour may be another checkout's, running: kept
    out = child("from proxyshade.cli import main; main(['cache', 'clean'])")
    assert "(0 folder(s) or file(s)" in out and "1 other version(s) used in the last hour" in out
    assert Path(first["folder"]).is_dir()
    for base, dirs, files in os.walk(first["folder"]):  # idle for two hours: removed
        for f in [base, *(os.path.join(base, f) for f in files)]:
            os.utime(f, (time.time() - 7200, time.time() - 7200))
    out = child("from proxyshade.cli import main; main(['cache', 'clean'])")
    assert "compiled kernels of other versions (1 folder(s) or file(s)" in out
    assert sorted(p.name for p in (tmp_path / "numba" / "proxyshade-kernels").iterdir()
                  if p.is_dir()) == [Path(edited["folder"]).name]


def test_precompiled_marks_belong_to_one_version(tmp_path, monkeypatch):
    """``kernels_cached`` is true for the modules marked in this version's folder only: a
    new version (an edit, an upgrade) starts unmarked."""
    from proxyshade.kernels import _cache

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    mods = ["proxyshade.kernels.random", "proxyshade.kernels.layout"]
    assert not _cache.kernels_cached(mods)
    _cache.mark_precompiled(mods[:1])
    assert _cache.kernels_cached(mods[:1]) and not _cache.kernels_cached(mods)
    _cache.mark_precompiled(mods)
    assert _cache.kernels_cached(mods)
    here = _cache.folder()
    monkeypatch.setattr(_cache, "version", lambda: "another")
    assert not _cache.kernels_cached(mods[:1])
    old = [p for p, _ in _cache.info()["old"]]  # (and numba files an older checkout left beside the sources)
    assert here in old and not any(p.parent == here.parent and p != here for p in old)


def test_the_version_covers_every_kernel_source_and_numba_and_numpy(monkeypatch, tmp_path):
    """The version is the same from the memo file and computed afresh, and changes with
    numba's or numpy's version."""
    from proxyshade.kernels import _cache

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    _cache.version.cache_clear()
    try:
        v = _cache.version()
        assert (tmp_path / "proxyshade-kernels" / "versions.json").is_file()
        _cache.version.cache_clear()
        assert _cache.version() == v  # from the memo
        (tmp_path / "proxyshade-kernels" / "versions.json").unlink()
        _cache.version.cache_clear()
        assert _cache.version() == v  # computed again
        _cache.version.cache_clear()
        monkeypatch.setattr(_cache, "_library_versions", lambda: [["numba", "0.0"], ["numpy", "9.9"]])
        assert _cache.version() != v
    finally:
        monkeypatch.undo()
        _cache.version.cache_clear()
