"""Refactor check: every EXR under folder A and its namesake under folder B hold the same
channels, bit for bit (native types, OpenEXR), and whether the files are byte-identical
(headers may differ by paths). Exit 1 when a file is missing or a channel differs.

    python bench/compare_exrs.py /tmp/before /tmp/after   # folders of `proxyshade run --var out=...`
"""
import hashlib
import sys
from pathlib import Path

import OpenEXR

a, b = Path(sys.argv[1]), Path(sys.argv[2])
bad = 0
for fa in sorted(p for p in a.rglob("*.exr") if "cache" not in p.parts):
    fb = b / fa.relative_to(a)
    if not fb.exists():
        print("MISSING", fb); bad += 1; continue
    same_bytes = hashlib.sha256(fa.read_bytes()).digest() == hashlib.sha256(fb.read_bytes()).digest()
    A, B = OpenEXR.File(str(fa)), OpenEXR.File(str(fb))
    ca, cb = A.channels(), B.channels()
    diff = [k for k in ca if k not in cb or ca[k].pixels.dtype != cb[k].pixels.dtype
            or ca[k].pixels.tobytes() != cb[k].pixels.tobytes()] + [k for k in cb if k not in ca]
    ha, hb = A.header(), B.header()
    hdiff = [k for k in set(ha) | set(hb) if str(ha.get(k)) != str(hb.get(k))]
    ok = not diff
    bad += not ok
    print(f"{'OK  ' if ok else 'DIFF'} {fa.relative_to(a)}: {len(ca)} channel groups pixel-exact={not diff}, "
          f"bytes-identical={same_bytes}, header keys differing={sorted(hdiff)}" + (f" channels differing: {diff}" if diff else ""))
sys.exit(1 if bad else 0)
