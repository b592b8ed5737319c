"""Fast guided synthesis (Bonneel et al. 2010, §5): per-stage medians like the paper's
Table 1, at 256² synthesis / 1024² output, on each sample's second label layout.

Stages (kernels, as the nodes call them):
  features     source -> exemplar, label stack/pyramid, contour distances, Chamfer masks,
               similarity sets (PatchInit's finest level + Correct's levels)
  flood fill   patch growth (PatchInit)
  corrections  k-coherent correction passes 32² -> 256² (Correct)
  magnify      patch upsampling to 1024², label repair, patch ids, colour lookup (Magnify)
  Poisson      seam gradients + multigrid-preconditioned CG, 1024² x 3 (Poisson)
Then each node's median through ``run_node`` (which repeats the shared set-up), and the
label fidelity / patch counts of the result. Run: ``python bench/run.py synthesis``.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from harness import measure, peak_rss_mb, table

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from proxyshade.graph.plate import Plate  # noqa: E402
from proxyshade.graph.testing import run_node  # noqa: E402
from proxyshade.io.source import labels_from_map, load_source  # noqa: E402
from proxyshade.kernels import multigrid as kmg  # noqa: E402
from proxyshade.kernels import poisson as kpo  # noqa: E402
from proxyshade.synthesis.params import PoissonSolve  # noqa: E402

SOLVE = dict(tol=PoissonSolve.tol.default, max_iter=PoissonSolve.max_iter.default)
from proxyshade.kernels.lookup import lookup  # noqa: E402
from proxyshade.synthesis import labels as L  # noqa: E402
from proxyshade.synthesis.exemplar import synthesis_setup  # noqa: E402
from proxyshade.synthesis.params import Correction, FloodFill  # noqa: E402
from proxyshade.synthesis.patches import correct_map, fill_patches, magnify_map, similarity_sets  # noqa: E402

OUT = 1024
FACTOR = 4


def guide_for(src: Plate, size: int = OUT) -> Plate:
    ids, _ = labels_from_map(Path(src.meta["source"]["layout"]), src.meta["labels"], far_distance=100.0,
                             max_far_fraction=0.05, where="bench")
    ids = ids[(np.arange(size) * ids.shape[0] // size)][:, (np.arange(size) * ids.shape[1] // size)]
    return Plate({"label.id": ids.astype(np.uint32)}, {"labels": src.meta["labels"]})


def stages(sample: str, repeat: int) -> tuple[list, dict]:
    src = load_source(ROOT / "samples" / sample / "source.yaml")
    guide = guide_for(src)
    table_ids = L.source_table(src)
    n = len(table_ids)
    g_dense = L.dense_guide(guide["label.id"], table_ids)
    tgt = L.guide_at_synthesis(g_dense, FACTOR, n)
    corr, fill = Correction.defaults(), FloodFill.defaults()
    state: dict = {}

    def features():
        setup = synthesis_setup(src, tgt, table_ids, factor=FACTOR, scale=1.0, coarse_size=corr.coarse_size,
                                max_distance=corr.max_distance, with_rgb=corr.use_rgb)
        state["sims"] = similarity_sets(setup, corr, seed=0)
        state["setup"] = setup

    def flood():
        state["coords0"], _, state["npatch"] = fill_patches(state["setup"], fill, seed=0)

    def corrections():
        state["S"], _, _ = correct_map(state["setup"], state["coords0"], corr, seed=0, similarity=state["sims"])

    def magnify():
        wl = L.working_labels(L.source_dense(src, table_ids), 1.0, n)
        state["sx"], state["sy"], state["patch"], _, _ = magnify_map(state["S"], FACTOR, guide.shape, scale=1.0,
                                                                    target=g_dense, labels=wl)
        state["rgb"] = lookup(src.rgb(), state["sx"], state["sy"])

    def poisson():
        gx, gy = kpo.seam_gradients(src.rgb(), state["sx"], state["sy"])
        state["u"], state["pinfo"] = kpo.poisson_transfer(state["rgb"], state["patch"], guide["label.id"],
                                                          seam_gx=gx, seam_gy=gy, screen=0.01, **SOLVE)

    rows = []
    for name, fn in (("features", features), ("flood fill", flood), ("corrections", corrections),
                     ("magnify", magnify), ("Poisson 1024^2 x 3", poisson)):
        rows.append((f"{sample}: {name}", measure(fn, repeat=repeat), None))
    # the solver alone on this frame (target 0.3 s on 2 cores)
    fx = kpo.contour_mask(guide["label.id"])
    b = np.empty(state["rgb"].shape, np.float32)
    gx, gy = kpo.seam_gradients(src.rgb(), state["sx"], state["sy"])
    kpo._rhs(state["rgb"], state["patch"], fx, np.zeros_like(b), gx, gy, b)
    rows.append((f"{sample}: Poisson solve only", measure(lambda: kmg.solve_system(fx, b, screen=0.01, **SOLVE), repeat=repeat),
                 0.3))
    src_l = lookup(src["label.id"], state["sx"], state["sy"])
    info = {"fidelity": float((src_l == guide["label.id"]).mean()), "patches": int(state["patch"].max()),
            "flood patches": int(state["npatch"]), "poisson": state["pinfo"],
            "exemplar": state["setup"].ex_lab.shape}
    return rows, info


def nodes(sample: str, repeat: int) -> list:
    src = load_source(ROOT / "samples" / sample / "source.yaml")
    guide = guide_for(src)
    out: dict = {}

    def run(name, typ, params, inputs):
        def fn():
            out[name] = run_node(typ, params, {k: (out[v] if isinstance(v, str) else v) for k, v in inputs.items()})
        return fn

    steps = [("init", "PatchInit", {}, {"guide": guide, "source": src}),
             ("correct", "Correct", {}, {"init": "init", "source": src}),
             ("magnify", "Magnify", {}, {"synth": "correct", "source": src, "guide": guide}),
             ("poisson", "Poisson", {}, {"image": "magnify", "source": src})]
    rows = []
    total = 0.0
    for name, typ, params, inputs in steps:
        m = measure(run(name, typ, params, inputs), repeat=repeat)
        total += m["median"]
        rows.append((f"{sample}: node {typ}", m, None))
    rows.append((f"{sample}: nodes PatchInit..Poisson", {"median": total, "min": total, "max": total, "n": repeat},
                 None))
    return rows


def main(repeat: int = 5, samples=("renoir", "monet", "creek")):
    for s in samples:
        t0 = time.perf_counter()
        rows, info = stages(s, repeat)
        table(f"synthesis stages, {s} (256^2 synthesis, 1024^2 output, exemplar {info['exemplar'][1]}x"
              f"{info['exemplar'][0]})", rows)
        print(f"label fidelity {info['fidelity']:.4%}, {info['flood patches']} flood-fill patches at 256^2, "
              f"{info['patches']} patches at 1024^2, Poisson {info['poisson']['iterations']} iterations")
        table(f"synthesis nodes, {s}", nodes(s, repeat))
        print(f"({time.perf_counter() - t0:.0f} s for this sample; peak RSS {peak_rss_mb():.0f} MiB)")


if __name__ == "__main__":
    main()
