"""Several graphs in one run (shots, variants, a parameter sweep): prepared together and
computed at once on a distributed executor (``dask_executor.DaskExecutor``), one after the
other on a local one; two of them writing one file is an error before anything runs.
Kept apart from the Dask executor so a local run does not import what Dask needs."""
from __future__ import annotations

from proxyshade.errors import UserError


def run_graphs(items, *, executor=None, jobs: int = 1, force: tuple[str, ...] = (), hooks=None,
               threads: int = 0, labels: list[str] | None = None) -> list:
    """Run several graphs (shots, variants; ``items``: (graph, frames or None) pairs):
    prepared together and computed at once on a distributed executor (a key two graphs
    share is computed once), one after the other on a local one. ``hooks``: a function of
    the graph giving its ``Hooks`` (progress), or None; ``labels``: the graphs' names in
    messages (default: their files). Two graphs writing one file is an error before anything runs."""
    from proxyshade.graph.executor import make_executor

    labels = labels or [g.source or g.name for g, _ in items]
    check_outputs([(label, g, f) for label, (g, f) in zip(labels, items)])
    executor = executor or make_executor(jobs)
    hooks = hooks or (lambda g: None)
    if not getattr(executor, "distributed", False):
        return [g.run(f, executor=executor, force=force, hooks=hooks(g), threads=threads) for g, f in items]
    prepared = [g.prepare(f, force=force, hooks=hooks(g), threads=threads) for g, f in items]
    for job, label in zip(prepared, labels):
        job.label = label
    executor.run_jobs(prepared)
    return [job.finish() for job in prepared]


def check_outputs(shots) -> None:
    """Two of ``shots`` ((label, graph, frames or None)) writing one file: a one-line error naming both."""
    if len(shots) < 2:
        return
    seen: dict[str, str] = {}
    for label, g, frames in shots:
        dag = g.instances(list(frames) if frames else list(range(g.frames[0], g.frames[1] + 1)))
        for path in sorted(set(g.output_files(dag))):
            other = seen.setdefault(str(path), label)
            if other != label:
                raise UserError(f"{other} and {label} both write {path}; give each its own output "
                                "(a variable in the output path, e.g. --var out=... or --sweep out=a,b)")
