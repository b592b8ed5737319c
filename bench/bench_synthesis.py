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
from proxyshade.kernels import correct as kc  # noqa: E402
from proxyshade.kernels.random import mix_seed  # noqa: E402
from proxyshade.kernels import features as kf  # noqa: E402
from proxyshade.kernels import magnify as km  # noqa: E402
from proxyshade.kernels import patch as kp  # noqa: E402
from proxyshade.kernels import poisson as kpo  # noqa: E402
from proxyshade.kernels.lookup import lookup  # noqa: E402
from proxyshade.nodes import patch_init as npi  # noqa: E402

OUT = 1024
FACTOR = 4


class _Ctx:
    def error(self, msg):
        return RuntimeError(msg)


def guide_for(src: Plate, size: int = OUT) -> Plate:
    ids, _ = labels_from_map(Path(src.meta["source"]["layout"]), src.meta["labels"], far_distance=100.0,
                             max_far_fraction=0.05, where="bench")
    ids = ids[(np.arange(size) * ids.shape[0] // size)][:, (np.arange(size) * ids.shape[1] // size)]
    return Plate({"label.id": ids.astype(np.uint32)}, {"labels": src.meta["labels"]})


def stages(sample: str, repeat: int) -> tuple[list, dict]:
    src = load_source(ROOT / "samples" / sample / "source.yaml")
    guide = guide_for(src)
    ctx = _Ctx()
    table_ids = npi.source_table(ctx, src)
    n = len(table_ids)
    g_dense = npi.dense_guide(ctx, guide["label.id"], table_ids)
    tgt = npi.guide_at_synthesis(ctx, g_dense, FACTOR, n)
    state: dict = {}

    def features():
        st = npi.setup(ctx, src, tgt, table_ids, factor=FACTOR, scale=1.0, coarse_size=32, max_distance=8.0,
                       with_rgb=True)
        knns = [None] * len(st.levels)
        for l in range(len(st.levels) - 1, -1, -1):
            init = knns[l + 1] if l + 1 < len(st.levels) else None
            knns[l] = kc.similarity_sets(st.levels[l], 2, seed=mix_seed(0, l), iterations=2 if init is None else 1,
                                         init=init)
        state["st"] = st

    def flood():
        fin = state["st"].levels[-1]
        state["S0"], _, state["npatch"] = kp.flood_fill(fin.src_lab, fin.src_dist, fin.src_masks, fin.tgt_lab,
                                                        fin.tgt_dist, fin.tgt_masks, seed=0)

    def corrections():
        tm: dict = {}
        state["S"], _ = kc.synthesize(state["st"].levels, state["S0"], k=2, timings=tm)
        state["corr_only"] = tm["corrections"]

    def magnify():
        Sw = km.magnify(state["S"], FACTOR, guide.shape)
        src_dense, _ = kf.dense_labels(src["label.id"], table_ids)
        Sw, _ = km.repair_labels(Sw, g_dense, src_dense)
        state["patch"], _ = kp.offset_components(Sw)
        state["sx"] = Sw[..., 1].astype(np.float32)
        state["sy"] = Sw[..., 0].astype(np.float32)
        state["rgb"] = lookup(src.rgb(), state["sx"], state["sy"])

    def poisson():
        gx, gy = kpo.seam_gradients(src.rgb(), state["sx"], state["sy"])
        state["u"], state["pinfo"] = kpo.poisson_transfer(state["rgb"], state["patch"], guide["label.id"],
                                                          seam_gx=gx, seam_gy=gy, screen=0.01)

    rows = []
    for name, fn in (("features", features), ("flood fill", flood), ("corrections", corrections),
                     ("magnify", magnify), ("Poisson 1024^2 x 3", poisson)):
        rows.append((f"{sample}: {name}", measure(fn, repeat=repeat), None))
    # the solver alone on this frame (target 0.3 s on 2 cores)
    fx = kpo.contour_mask(guide["label.id"])
    b = np.empty(state["rgb"].shape, np.float32)
    gx, gy = kpo.seam_gradients(src.rgb(), state["sx"], state["sy"])
    kpo._rhs(state["rgb"], state["patch"], fx, np.zeros_like(b), gx, gy, b)
    rows.append((f"{sample}: Poisson solve only", measure(lambda: kpo.solve_system(fx, b, screen=0.01), repeat=repeat),
                 0.3))
    src_l = lookup(src["label.id"], state["sx"], state["sy"])
    info = {"fidelity": float((src_l == guide["label.id"]).mean()), "patches": int(state["patch"].max()),
            "flood patches": int(state["npatch"]), "poisson": state["pinfo"],
            "exemplar": state["st"].ex_lab.shape}
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
