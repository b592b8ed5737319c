"""Imported by the forkserver that a LocalCluster's Dask workers are forked from
(``dask_executor._start_method``): loads what every worker needs, once for all of them
(``dask_executor.load_worker_image``)."""
from proxyshade.graph.dask_executor import load_worker_image

load_worker_image()
