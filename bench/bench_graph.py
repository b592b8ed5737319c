"""Engine overhead: per-node medians of the demo graph and its cache-hit re-run time."""
from pathlib import Path

from harness import graph_node_medians, print_graph_medians

ROOT = Path(__file__).resolve().parents[1]


def main():
    res = graph_node_medians(ROOT / "graphs" / "import_source.yaml", repeat=5)
    print_graph_medians("source import graph (graphs/import_source.yaml)", res)


if __name__ == "__main__":
    main()
