"""Run every benchmark module (``bench/bench_*.py``) or those named: ``python bench/run.py proxy_render``."""
import importlib.util
import sys
from pathlib import Path

here = Path(__file__).parent
sys.path.insert(0, str(here))
if __name__ == "__main__":  # not again in worker processes that import this file (Dask's LocalCluster)
    wanted = set(sys.argv[1:])
    for path in sorted(here.glob("bench_*.py")):
        if wanted and path.stem.removeprefix("bench_") not in wanted:
            continue
        spec = importlib.util.spec_from_file_location(path.stem, path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        mod.main()
